"""The user guide at /docs (issue 42): rendered from the package's Markdown by the running server, offline,
under the page's Host and security rules, and never a 500 or a file outside the guide for a crafted path."""

from __future__ import annotations

import dataclasses
import http.client
import re
from pathlib import Path

import pytest
import requests

from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.web.guide import Guide, docs_dir
from tests.conftest import ServerFactory, make_settings

TIMEOUT = 10


def _raw_get(port: int, path: str, host: str = "127.0.0.1") -> tuple[int, str, dict[str, str]]:
    """GET ``path`` exactly as written (requests would normalise ``..`` away before sending it)."""
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=TIMEOUT)
    try:
        conn.putrequest("GET", path, skip_host=True)
        conn.putheader("Host", host)
        conn.endheaders()
        reply = conn.getresponse()
        return reply.status, reply.read().decode("utf-8", "replace"), dict(reply.getheaders())
    finally:
        conn.close()


def test_the_contents_page_lists_every_page_and_links_work(base_url: str) -> None:
    page = requests.get(base_url + "/docs", timeout=TIMEOUT)
    assert page.status_code == 200 and page.headers["Content-Type"].startswith("text/html")
    assert "<title>The alpaca-zwo guide · alpaca-zwo guide</title>" in page.text
    links = sorted(set(re.findall(r'href="(/docs/[a-z0-9-]+)(?:#[^"]*)?"', page.text)))
    assert "/docs/first-night" in links and "/docs/configuration" in links and "/docs/meridian" in links
    for link in links:  # every page the contents names is served
        reply = requests.get(base_url + link, timeout=TIMEOUT)
        assert reply.status_code == 200, (link, reply.status_code)
        assert '<link rel="stylesheet" href="/setup/static/style.css">' in reply.text
        assert '<script src="/setup/static/night.js"></script>' in reply.text


def test_pages_carry_the_pages_security_headers_and_no_script_of_their_own(base_url: str) -> None:
    reply = requests.get(base_url + "/docs/first-night", timeout=TIMEOUT)
    assert reply.status_code == 200
    assert "script-src 'self'" in reply.headers["Content-Security-Policy"]
    assert reply.headers["X-Frame-Options"] == "DENY"
    assert re.findall(r"<script[^>]*>", reply.text) == ['<script src="/setup/static/night.js">']
    assert "http://" not in re.sub(r'href="http[^"]*"', "", reply.text).split("<main", 1)[0]  # no CDN


def test_headings_get_the_code_hosts_anchors_and_links_are_rewritten(base_url: str) -> None:
    text = requests.get(base_url + "/docs/first-night", timeout=TIMEOUT).text
    assert 'id="3-open-the-page-on-your-phone"' in text
    assert 'href="/docs/install#start-at-boot"' in text
    hand = requests.get(base_url + "/docs/hand-controller", timeout=TIMEOUT).text
    shot = re.search(r'<img src="(/docs/screenshots/[a-z0-9-]+\.png)"', hand)
    assert shot, "the hand controller page shows a screenshot"
    image = requests.get(base_url + shot.group(1), timeout=TIMEOUT)
    assert image.status_code == 200 and image.headers["Content-Type"] == "image/png"
    assert image.content.startswith(b"\x89PNG")
    actions = requests.get(base_url + "/docs/actions", timeout=TIMEOUT).text
    assert 'id="zwobuzzervolume"' in actions


def test_markdown_cannot_inject_html(tmp_path: Path) -> None:
    """Raw HTML in a page is shown as text, never run (the guide ships as files anyone may edit)."""
    (tmp_path / "guide").mkdir()
    page = tmp_path / "guide" / "index.md"
    page.write_text('# T <b>x</b>\n\n<script>alert(1)</script>\n\n[x](javascript:alert(1)) ![i](../../etc/passwd)\n')
    _, body = Guide(tmp_path).render(page)
    assert "<script>" not in body and "&lt;script&gt;" in body
    assert 'href="javascript:' not in body  # shown as text, not a link
    assert "etc/passwd" not in body and "<b>" not in body


@pytest.mark.parametrize("path", [
    "/docs/../../etc/passwd", "/docs/..", "/docs/%2e%2e", "/docs/..%2f..%2fpyproject.toml", "/docs/index.md",
    "/docs/ARCHITECTURE", "/docs/no-such-page", "/docs/guide%2findex", "/docs/screenshots/..%2f..%2fREADME.md",
    "/docs/screenshots/nothing.png", "/docs/screenshots/MANIFEST.json", "/docs/%00", "/docs/" + "a" * 5000,
])
def test_unknown_pages_and_traversal_get_404_with_text(live_server: AlpacaZwoServer, path: str) -> None:
    status, body, _ = _raw_get(live_server.port, path)
    assert status in (400, 404), (path, status, body)
    assert body.strip() and "Traceback" not in body and "/work" not in body and "root:" not in body


def test_the_guide_is_served_under_any_host_like_the_page_but_the_api_is_not(live_server: AlpacaZwoServer) -> None:
    status, body, _ = _raw_get(live_server.port, "/docs", host="rebind.example")
    assert status == 200 and "The alpaca-zwo guide" in body
    status, _, _ = _raw_get(live_server.port, "/setup/api/server", host="rebind.example")
    assert status == 403


def test_the_guide_is_behind_basic_auth(server_factory: ServerFactory) -> None:
    settings = make_settings()
    settings = dataclasses.replace(settings, server=dataclasses.replace(
        settings.server, basic_auth_user="astro", basic_auth_password="secret"))
    server = server_factory(settings)
    url = f"http://127.0.0.1:{server.port}/docs"
    assert requests.get(url, timeout=TIMEOUT).status_code == 401
    assert requests.get(url, auth=("astro", "secret"), timeout=TIMEOUT).status_code == 200


def test_docs_dir_holds_the_guide() -> None:
    assert (docs_dir() / "guide" / "index.md").is_file()
