"""The page itself: ``/setup`` (``/`` redirects there), the per-device setup URL and the static files they load.

Static files are served from a list of names that exist in the package's ``static`` directory,
never by joining a client-supplied path.
"""

from __future__ import annotations

import contextlib
import hashlib
import html
import importlib.resources
import mimetypes
import re
from pathlib import Path

import falcon

from ..facade import ServerFacade
from .http import secure

_CONTENT_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".svg": "image/svg+xml",
    ".ico": "image/x-icon",
    ".png": "image/png",
    ".json": "application/json",
}
# No leading dot (no ".." and no hidden files), no separators of any kind, a known extension.
_STATIC_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}")


def static_dir() -> Path:
    """The page's files: the installed ``alpaca_zwo.static`` package, else ``static/`` beside the source."""
    with contextlib.suppress(ModuleNotFoundError, TypeError, ValueError):
        index = importlib.resources.files("alpaca_zwo.static").joinpath("index.html")
        if isinstance(index, Path) and index.is_file():
            return index.parent.resolve()
    return (Path(__file__).resolve().parents[2] / "static").resolve()


class StaticFiles:
    """``GET /setup/static/{name}``: one file directly inside the static directory, or 404.

    The name is checked against a strict pattern and the resolved file must still sit directly in
    the resolved directory and not be a symlink, so neither ``..`` (plain or percent-encoded), an
    absolute path nor a link planted in the directory can reach anything else.
    """

    #: Served whatever Host names (the app's host check skips its GETs): nothing here is private,
    #: and a page opened by an unknown name then shows why its API calls are refused.
    any_host = True

    def __init__(self, root: Path) -> None:
        self.root = root.resolve()

    def find(self, name: str) -> Path | None:
        if not _STATIC_NAME.fullmatch(name) or Path(name).suffix.lower() not in _CONTENT_TYPES:
            return None
        candidate = self.root / name
        try:
            if candidate.is_symlink() or not candidate.is_file():
                return None
            resolved = candidate.resolve(strict=True)
        except OSError:
            return None
        return resolved if resolved.parent == self.root else None

    def serve(self, req: falcon.Request, resp: falcon.Response, name: str, cache: str) -> None:
        path = self.find(name)
        if path is None:
            raise falcon.HTTPNotFound(description=f"No such file {name!r}")
        data = path.read_bytes()
        etag = '"' + hashlib.sha256(data).hexdigest()[:32] + '"'
        secure(resp)
        resp.content_type = _CONTENT_TYPES.get(path.suffix.lower()) or mimetypes.guess_type(name)[0] or "text/plain"
        resp.cache_control = [cache]
        resp.set_header("ETag", etag)
        if etag in (req.get_header("If-None-Match") or "").replace(" ", "").split(","):
            resp.status = falcon.HTTP_304
            return
        resp.data = data

    def on_get(self, req: falcon.Request, resp: falcon.Response, name: str) -> None:
        # Revalidate every time: cheap on a LAN, and a server upgrade never mixes old and new files.
        self.serve(req, resp, name, "no-cache")


class SetupPage:
    """``GET /setup``: the whole-server page (it shows device 0 and lets the user pick another)."""

    any_host = True  # as StaticFiles

    def __init__(self, files: StaticFiles) -> None:
        self._files = files

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        self._files.serve(req, resp, "index.html", "no-cache")


class RootRedirect:
    """``GET /`` (and ``/index.html``): 302 to ``/setup``, so ``http://host:11111/`` typed by hand finds the page.

    302, not 301: a browser caches a 301 for good, and the root must stay free for later use. Only
    these exact paths redirect; every other unmatched path keeps the Alpaca sink's answer (400 for
    a malformed device path, 403 for an unknown management method, else 404). The Location is a
    path, so it follows whatever name or proxy the browser used.
    """

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        raise falcon.HTTPFound("/setup")

    on_head = on_get


class DeviceSetupPage:
    """``GET /setup/v1/{device_type}/{device_number}/{page}``: 403 for anything but our telescopes' ``setup``."""

    any_host = True  # as StaticFiles

    def __init__(self, facade: ServerFacade, files: StaticFiles) -> None:
        self._facade = facade
        self._files = files

    def on_get(self, req: falcon.Request, resp: falcon.Response, device_type: str, device_number: str,
               page: str) -> None:
        numbers = [str(i) for i in range(self._facade.device_count)]
        if device_type != "telescope" or device_number not in numbers or page != "setup":
            # The Management API documents text/html for this 403, like the page itself.
            message = (f"No setup page for {device_type}/{device_number}/{page}: this server has telescope "
                       f"{', '.join(numbers) or 'none'} (/setup/v1/telescope/N/setup)")
            resp.status = falcon.HTTP_403
            resp.content_type = falcon.MEDIA_HTML
            resp.text = f"<!DOCTYPE html><title>No such device</title><p>{html.escape(message)}</p>"
            return
        self._files.serve(req, resp, "index.html", "no-cache")
