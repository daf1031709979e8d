"""Docs that cannot drift (issue 42): the README and the guide name only what exists.

Read with the same Markdown parser the server renders with (markdown-it-py), so a link or a code span is
found exactly where a reader sees one:

- every relative link and image resolves to a file, and every ``#anchor`` to a heading of its page
  (GitHub's heading slugs, which the server's /docs uses too);
- the generated references (configuration keys, command-line options) are what the code defines now;
- a command-line flag, a configuration key or table, a ``zwo:`` Action or an API route quoted in code
  exists (flags: the two programs' parsers; keys: the settings schema, and every TOML example is a
  valid configuration; routes: asked of a running server);
- no screenshot is older than the page it shows (docs/screenshots/MANIFEST.json, tools/screenshots.py).
"""

from __future__ import annotations

import re
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import requests
from markdown_it import MarkdownIt
from markdown_it.token import Token

from alpaca_zwo.cli import build_parser as server_parser
from alpaca_zwo.config.settings import Settings, settings_from_dict
from alpaca_zwo.emulator.cli import build_parser as emulator_parser
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope.actions import ACTIONS
from alpaca_zwo.web.guide import Guide, heading_ids
from tools import make_reference, screenshots

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
#: What a user reads: the README, the guide and the notes the guide serves.
READ = [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md")),
        *(ROOT / "docs" / f"{name}.md" for name in ("meridian", "southern", "objects", "survey", "pointing-errors",
                                                     "satellites"))]
#: Every Markdown file whose links must hold (ARCHITECTURE.md is the developers' map).
LINKED = [*READ, ROOT / "docs" / "ARCHITECTURE.md"]
#: Flags of other programs the guide quotes (pip, podman/docker, systemctl).
FOREIGN_FLAGS = {"--break-system-packages", "--user", "--format", "--network", "--now"}
_MD = MarkdownIt("commonmark", {"html": False}).enable("table")


def _tokens(path: Path) -> list[Token]:
    return _MD.parse(path.read_text(encoding="utf-8"))


def _inline(tokens: list[Token]) -> Iterator[Token]:
    for token in tokens:
        yield token
        yield from token.children or ()


def _code(path: Path) -> Iterator[tuple[str, str]]:
    """Each code span's and code block's text, with the block's language."""
    for token in _inline(_tokens(path)):
        if token.type in ("fence", "code_block"):
            yield token.content, token.info.strip()
        elif token.type == "code_inline":
            yield token.content, ""


def _anchors(path: Path) -> set[str]:
    return {anchor for _, anchor in heading_ids(_tokens(path))}


def _name(path: Path) -> str:
    return str(path.relative_to(ROOT))


# --- links ----------------------------------------------------------------------------------------


def _links(path: Path) -> Iterator[str]:
    for token in _inline(_tokens(path)):
        if token.type == "link_open":
            yield str(token.attrGet("href"))
        elif token.type == "image":
            yield str(token.attrGet("src"))


def test_every_internal_link_and_anchor_resolves() -> None:
    broken = []
    for page in LINKED:
        for href in _links(page):
            if re.match(r"[a-z][a-z0-9+.-]*:", href):  # http(s), mailto: outside the repository
                continue
            path, _, anchor = href.partition("#")
            target = (page.parent / path).resolve() if path else page
            if not target.exists():
                broken.append(f"{_name(page)}: {href} (no such file)")
            elif anchor and target.suffix == ".md" and anchor not in _anchors(target):
                broken.append(f"{_name(page)}: {href} (no heading #{anchor} in {_name(target)})")
    assert broken == []


def test_the_pages_help_links_reach_a_section_of_the_guide() -> None:
    """The setup page's Help link and each setting's "?" (static/index.html) open a page and heading that exist."""
    page = (ROOT / "static" / "index.html").read_text(encoding="utf-8")
    links = re.findall(r'href="/docs(?:/([a-z0-9-]+))?(?:#([^"]*))?"', page)
    assert len(links) >= 10 and ("", "") in links
    guide = Guide(ROOT / "docs")
    broken = []
    for name, anchor in links:
        found = guide.find(name or "index")
        if found is None or (anchor and anchor not in _anchors(found)):
            broken.append(f"/docs/{name}#{anchor}")
    assert broken == []


def test_the_guide_has_a_page_for_each_task_and_the_contents_lists_them_all() -> None:
    guide = ROOT / "docs" / "guide"
    listed = set(re.findall(r"\]\(([a-z0-9-]+)\.md\)", (guide / "index.md").read_text(encoding="utf-8")))
    pages = {path.stem for path in guide.glob("*.md") if path.stem.islower() and path.stem != "index"}
    assert pages - listed == set(), "pages missing from the guide's contents (docs/guide/index.md)"
    for task in ("first-night", "clients", "hand-controller", "field", "observatory", "southern-hemisphere",
                 "sharing", "mount-settings", "security", "command-line", "configuration", "troubleshooting",
                 "emulator"):
        assert task in pages


def test_the_readme_is_a_front_door() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 150
    assert text.count("<img ") + text.count("![") == 1, "one screenshot"
    for name in ("N.I.N.A.", "Stellarium", "KStars", "docs/guide/", "./scripts/run-tests"):
        assert name in text


# --- the generated references ---------------------------------------------------------------------


def test_the_configuration_and_command_line_references_are_up_to_date() -> None:
    stale = [_name(path) for path in make_reference.stale()]
    assert stale == [], f"out of date: {stale}; regenerate them with: {make_reference.COMMAND}"


def test_the_configuration_reference_names_every_key() -> None:
    text = (ROOT / "docs" / "guide" / "configuration.md").read_text(encoding="utf-8")
    assert "(not explained yet" not in text, "a key without a #: comment in alpaca_zwo/config/settings.py"
    for section, keys in _schema().items():
        heading = "[[devices]]" if section == "devices" else f"[{section}]"
        assert f"## {heading}" in text
        part = text.split(f"## {heading}", 1)[1].split("\n## ", 1)[0]
        for key in keys:
            assert f"| `{key}` |" in part, f"{section}.{key}"


# --- what is quoted exists ------------------------------------------------------------------------


def _schema() -> dict[str, set[str]]:
    """Each table of the configuration file and its keys, from the defaults' own dictionary."""
    from alpaca_zwo.config.settings import settings_to_dict

    data = settings_to_dict(Settings())
    return {name: set(value[0] if isinstance(value, list) else value) for name, value in data.items()}


def test_every_quoted_flag_exists() -> None:
    known = {flag for parser in (server_parser(), emulator_parser()) for action in parser._actions
             for flag in action.option_strings}
    unknown = {(_name(page), flag) for page in READ for text, _ in _code(page)
               for flag in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", text)
               if flag not in known | FOREIGN_FLAGS}
    assert unknown == set(), "flags no parser defines (another program's? add it to FOREIGN_FLAGS)"


def _unknown_keys(pages: list[Path]) -> set[tuple[str, str]]:
    """``section.key`` and ``[section]`` quoted in code that the settings schema does not have."""
    schema = _schema()
    unknown = set()
    for page in pages:
        for text, language in _code(page):
            for section, key in re.findall(r"(?<![\w./])([a-z_]+)\.([a-z_]+\*?)(?![\w(/])", text):
                if section not in schema or key in ("py", "md", "toml"):
                    continue
                if not any(name == key or (key.endswith("*") and name.startswith(key[:-1]))
                           for name in schema[section]):
                    unknown.add((page.name, f"{section}.{key}"))
            tables = re.findall(r"^\[{1,2}([a-z_]+)\]{1,2}$", text, re.MULTILINE) if language == "toml" else []
            if re.fullmatch(r"\[{1,2}[a-z_]+\]{1,2}", text):
                tables.append(text.strip("[]"))
            unknown |= {(page.name, f"[{table}]") for table in tables if table not in schema}
    return unknown


def test_every_quoted_configuration_key_exists() -> None:
    assert _unknown_keys(READ) == set()


@pytest.mark.parametrize(("quoted", "found"), [("`server.nosuch`", "server.nosuch"), ("`[nosuch]`", "[nosuch]"),
                                               ("`limits.horizon_*`", "limits.horizon_*")])
def test_the_key_check_sees_a_key_that_does_not_exist(tmp_path: Path, quoted: str, found: str) -> None:
    page = tmp_path / "page.md"
    page.write_text(f"Set {quoted}, `server.port` and `[site]` here.\n", encoding="utf-8")
    assert _unknown_keys([page]) == {("page.md", found)}


def test_every_toml_example_is_a_valid_configuration() -> None:
    """A TOML block in the docs is pasted into config files: it must load, with every key known."""
    blocks = [(page, text) for page in READ for text, language in _code(page) if language == "toml"]
    assert len(blocks) >= 4
    for page, text in blocks:
        data = tomllib.loads(text.replace('"…"', '""'))
        settings_from_dict(data, source=f"{_name(page)} example")  # raises ConfigError naming the key


def test_every_quoted_action_exists() -> None:
    names = {action.name for action in ACTIONS}
    quoted = {(_name(page), name) for page in READ
              for name in re.findall(r"\bzwo:[A-Za-z]+", page.read_text(encoding="utf-8"))}
    assert {(page, name) for page, name in quoted if name not in names} == set()
    assert {name for _, name in quoted} >= names, "an Action the guide never mentions"


#: A path of this server in code: its prefixes, then anything up to a space, quote, bracket or query.
_ROUTE = r"(?<![A-Za-z_./])(/(?:api|management|setup|docs)\b[^\s`)\"'<>,;?]*(?:<[^>]+>[^\s`)\"'<>,;?]*)*)"


def _routes() -> set[tuple[str, str]]:
    """The server's paths quoted in code: ``<placeholders>`` made a value, queries dropped; paths of
    other Alpaca devices (a SafetyMonitor's URL) are another server's and not asked here."""
    found = set()
    for page in READ:
        for text, _ in _code(page):
            for path in re.findall(_ROUTE, text):
                path = re.sub(r"<[^>]+>|\{[^}]+\}", "0", path).rstrip("/.") or "/"
                if re.match(r"/api/v1/(?!telescope/)", path):
                    continue
                found.add((_name(page), path))
    return found


def test_every_quoted_route_exists(live_server: AlpacaZwoServer) -> None:
    routes = _routes()
    assert any(path.startswith("/setup/api/") for _, path in routes)
    missing = []
    for page, path in sorted(routes):
        reply = requests.get(f"http://127.0.0.1:{live_server.port}{path}", timeout=10)
        # No route: the app's own 404 (alpaca/errors.py) or an unknown Alpaca member; a route's own 404
        # ("no survey yet", "no such telescope") means the route exists.
        if reply.text.startswith(("No such page", "Unknown")) or (reply.status_code == 404 and "/docs" in path):
            missing.append(f"{page}: {path} ({reply.status_code} {reply.text[:60]!r})")
    assert missing == []


# --- screenshots ----------------------------------------------------------------------------------


def test_no_screenshot_is_older_than_the_page_it_shows() -> None:
    problems = screenshots.problems()
    assert problems == [], "\n".join(problems)


def test_the_docs_show_only_recorded_screenshots() -> None:
    recorded = set(screenshots.manifest()["screenshots"])
    shown = {Path(href).name for page in READ for href in _links(page) if "screenshots/" in href and
             href.endswith(".png")}
    assert shown and shown <= recorded
