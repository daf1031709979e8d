"""The user guide at ``/docs``: the Markdown of ``docs/`` rendered from the installed package, offline.

The person holding a phone at the mount has no internet, so the guide ships inside the package
(``alpaca_zwo.docs``, mapped from the repository's ``docs/`` in pyproject.toml) and is rendered here
with markdown-it-py: no CDN, no script of its own, the page's own style sheet and night mode. Raw HTML
in the Markdown is not passed through (every character of the text is escaped), and a page is found
by looking its name up in the files that exist, never by joining a client-supplied path.

Links are written for the repository (``first-night.md#the-page``, ``../screenshots/x.png``) so they
also work on a code host; here they become ``/docs/first-night#the-page``. A link to a file of the
repository that is not part of the guide (``../ARCHITECTURE.md``) is shown as its text alone. Heading
ids follow the code host's rule (:func:`slug`), so one anchor works in both places.
"""

from __future__ import annotations

import contextlib
import html
import importlib.resources
import posixpath
import re
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import falcon
from markdown_it import MarkdownIt
from markdown_it.token import Token

from .http import secure

#: A page name as it appears in a URL: lower case, digits and hyphens (no dots, no separators).
_PAGE_NAME = re.compile(r"[a-z0-9][a-z0-9-]{0,63}")
_IMAGE_NAME = re.compile(r"[a-z0-9][a-z0-9-]{0,99}\.png")
_SCHEME = re.compile(r"[a-zA-Z][a-zA-Z0-9+.-]*:")


def docs_dir() -> Path:
    """The guide's files: the installed ``alpaca_zwo.docs`` package, else ``docs/`` beside the source."""
    with contextlib.suppress(ModuleNotFoundError, TypeError, ValueError):
        index = importlib.resources.files("alpaca_zwo.docs").joinpath("guide").joinpath("index.md")
        if isinstance(index, Path) and index.is_file():
            return index.parent.parent.resolve()
    return (Path(__file__).resolve().parents[2] / "docs").resolve()


def slug(text: str) -> str:
    """A heading's anchor as GitHub makes it: lower case, punctuation dropped, spaces to hyphens."""
    kept = re.sub(r"[^\w\- ]", "", text.strip().lower())
    return kept.replace(" ", "-")


def heading_text(inline: Token) -> str:
    """The visible text of a heading's inline token (code spans included, markup dropped)."""
    return "".join(child.content for child in inline.children or () if child.type in ("text", "code_inline"))


def heading_ids(tokens: Sequence[Token]) -> Iterator[tuple[Token, str]]:
    """Each heading's opening token with its unique anchor (a repeated one gets ``-1``, ``-2``...)."""
    seen: dict[str, int] = {}
    for i, token in enumerate(tokens):
        if token.type != "heading_open":
            continue
        base = slug(heading_text(tokens[i + 1]))
        count = seen.get(base, 0)
        seen[base] = count + 1
        yield token, base if count == 0 else f"{base}-{count}"


class Guide:
    """The guide's pages on disk and how one of them becomes HTML."""

    def __init__(self, root: Path) -> None:
        self.root = root.resolve()
        self._md = MarkdownIt("commonmark", {"html": False}).enable("table")
        self._md.add_render_rule("image", _render_image)

    def find(self, name: str) -> Path | None:
        """The Markdown file of page ``name`` (a guide page, else one of ``docs/``'s notes), or None."""
        if not _PAGE_NAME.fullmatch(name):
            return None
        for folder in (self.root / "guide", self.root):
            candidate = folder / f"{name}.md"
            if candidate.is_file() and not candidate.is_symlink() and candidate.resolve().parent == folder.resolve():
                return candidate
        return None

    def image(self, name: str) -> Path | None:
        if not _IMAGE_NAME.fullmatch(name):
            return None
        candidate = self.root / "screenshots" / name
        return candidate if candidate.is_file() and not candidate.is_symlink() else None

    def pages(self) -> list[tuple[str, str]]:
        """``(name, title)`` of the guide's pages in the order of its contents page."""
        index = self.find("index")
        names = re.findall(r"\]\(([a-z0-9-]+)\.md\)", index.read_text(encoding="utf-8")) if index else []
        found = [(name, path) for name in dict.fromkeys(names) if (path := self.find(name)) is not None]
        return [(name, _title(path.read_text(encoding="utf-8"), name)) for name, path in found]

    def render(self, path: Path) -> tuple[str, str]:
        """The page's title and its body as HTML."""
        text = path.read_text(encoding="utf-8")
        tokens = self._md.parse(text)
        for token, anchor in heading_ids(tokens):
            token.attrSet("id", anchor)
        where = path.parent.relative_to(self.root).as_posix()
        for token in tokens:
            _rewrite_links(token.children or [], where, self)
        return _title(text, path.stem), self._md.renderer.render(tokens, self._md.options, {})


def _title(text: str, fallback: str) -> str:
    match = re.search(r"^# (.+)$", text, flags=re.MULTILINE)
    return match.group(1).strip() if match else fallback


def target(href: str, where: str, guide: Guide) -> str | None:
    """Where a relative link of a page in folder ``where`` points on the server, or None for a file
    of the repository the server does not serve. Absolute URLs and in-page anchors are unchanged."""
    if not href or href.startswith(("#", "/")) or _SCHEME.match(href):
        return href
    path, _, fragment = href.partition("#")
    resolved = posixpath.normpath(posixpath.join(where, path))
    anchor = f"#{fragment}" if fragment else ""
    folder, _, name = resolved.rpartition("/")
    if folder == "screenshots" and guide.image(name) is not None:
        return f"/docs/screenshots/{name}"
    if folder in ("", "guide") and name.endswith(".md"):
        page = name.removesuffix(".md")
        found = guide.find(page)
        if found is not None and found.parent.relative_to(guide.root).as_posix() in (folder or ".", folder):
            return f"/docs/{page}{anchor}" if page != "index" else f"/docs{anchor}"
    return None


def _rewrite_links(children: list[Token], where: str, guide: Guide) -> None:
    unlinked = False
    for token in children:
        if token.type == "link_open":
            href = target(str(token.attrGet("href") or ""), where, guide)
            unlinked = href is None
            if unlinked:  # a file of the repository: its text stays, with the path as a hint
                token.tag, token.attrs = "span", {"class": "repo-file", "title": str(token.attrGet("href"))}
            else:
                token.attrSet("href", str(href))
        elif token.type == "link_close" and unlinked:
            token.tag, unlinked = "span", False
        elif token.type == "image":
            src = target(str(token.attrGet("src") or ""), where, guide)
            token.attrSet("src", src or "")


def _render_image(self: Any, tokens: Sequence[Token], idx: int, options: Any, env: Any) -> str:
    """An image in a frame that night mode turns red (style.css cannot recolour an ``<img>`` alone)."""
    token = tokens[idx]
    alt = html.escape(self.renderInlineAsText(token.children or [], options, env))
    src = html.escape(str(token.attrGet("src") or ""))
    if not src:  # not one of the guide's screenshots: its description alone
        return f'<span class="shot-missing">{alt}</span>'
    return f'<span class="shot"><img src="{src}" alt="{alt}" loading="lazy"></span>'


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title} · alpaca-zwo guide</title>
<link rel="icon" href="/setup/static/favicon.svg" type="image/svg+xml">
<link rel="stylesheet" href="/setup/static/style.css">
<link rel="stylesheet" href="/setup/static/guide.css">
<script src="/setup/static/night.js"></script>
</head>
<body class="guide-body">
<header class="guide-top">
<a href="/setup" class="guide-back">&larr; The mount</a>
<a href="/docs">Guide contents</a>
</header>
<main class="guide">
{body}
</main>
<nav class="guide-nav" aria-label="The guide's pages">
<ul>
{nav}
</ul>
</nav>
</body>
</html>
"""


class GuidePage:
    """``GET /docs`` (the contents) and ``GET /docs/{page}``: one page of the guide as HTML, or 404."""

    #: Served whatever Host names, as the setup page is (the app's host check skips its GETs): the
    #: guide is public text, and under basic auth like every route.
    any_host = True

    def __init__(self, guide: Guide) -> None:
        self._guide = guide

    def on_get(self, req: falcon.Request, resp: falcon.Response, page: str = "index") -> None:
        path = self._guide.find(page)
        if path is None:
            raise falcon.HTTPNotFound(description=f"No page {page!r} in the guide: its contents are at /docs")
        title, body = self._guide.render(path)
        nav = "\n".join(f'<li><a href="/docs/{name}">{html.escape(text)}</a></li>'
                        for name, text in self._guide.pages())
        secure(resp)
        resp.content_type = "text/html; charset=utf-8"
        resp.cache_control = ["no-cache"]
        resp.text = _PAGE.format(title=html.escape(title), body=body, nav=nav)


class GuideImage:
    """``GET /docs/screenshots/{name}``: a screenshot the guide shows, or 404."""

    any_host = True  # as GuidePage

    def __init__(self, guide: Guide) -> None:
        self._guide = guide

    def on_get(self, req: falcon.Request, resp: falcon.Response, name: str) -> None:
        path = self._guide.image(name)
        if path is None:
            raise falcon.HTTPNotFound(description=f"No screenshot {name!r}")
        secure(resp)
        resp.content_type = "image/png"
        resp.cache_control = ["no-cache"]
        resp.data = path.read_bytes()


def guide_routes(root: Path | None = None) -> list[tuple[str, object]]:
    """The guide's ``(uri_template, resource)`` pairs."""
    guide = Guide(root or docs_dir())
    page = GuidePage(guide)
    return [("/docs", page), ("/docs/{page}", page), ("/docs/screenshots/{name}", GuideImage(guide))]
