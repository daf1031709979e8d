"""The page's satellites over HTTP (issue 41): keep a TLE set, see it kept across a restart, list its passes
in the site's zone, warn about an old set, refuse bad input with a 400 (never a 500) and follow nothing
that does not pass soon. The follow itself is judged on the emulator in tests/motion/test_satellite_follow.py.
"""

from __future__ import annotations

from pathlib import Path

from tests.conftest import ServerFactory
from tests.web.test_setup_api import Client

ISS_TEXT = (Path(__file__).parents[1] / "support" / "tle" / "iss-2018-05-15.tle").read_text(encoding="utf-8")
PATH = "/setup/api/telescope/0/satellites"


def test_a_kept_set_survives_a_restart_and_an_old_one_is_flagged(server_factory: ServerFactory,
                                                                  tmp_path: Path) -> None:
    server = server_factory()
    client = Client(f"http://127.0.0.1:{server.port}")
    r = client.post(PATH, {"tle": ISS_TEXT})
    assert r.status_code == 200, r.text
    (kept,) = r.json()["satellites"]
    assert kept["name"] == "ISS (ZARYA)" and kept["number"] == 25544
    assert kept["epoch"]["utc"].startswith("2018-05-15T14:50:33")
    # Years old: flagged (its passes are listed, as SGP4 gives them, but not followed: see below).
    assert "days old" in kept["warning"]
    assert all(p["enters"]["site"] and p["max_altitude"] > 0 for p in kept["passes"])
    assert (tmp_path / "satellites.tle").read_text(encoding="utf-8") == ISS_TEXT
    server.stop()
    again = server_factory()
    listed = Client(f"http://127.0.0.1:{again.port}").session.get(
        f"http://127.0.0.1:{again.port}{PATH}", timeout=10).json()
    assert [s["name"] for s in listed["satellites"]] == ["ISS (ZARYA)"]
    assert listed["following"] is False and listed["progress"] is None and listed["site_zone"]


def test_bad_input_is_refused_with_the_reason(live_server: object, base_url: str) -> None:
    client = Client(base_url)
    for body, words in (({"tle": "ISS\n1 25544U nonsense"}, "line"),
                        ({"tle": ISS_TEXT.replace("51.6402", "51.6403")}, "checksum"),
                        ({"tle": 5}, "tle must be"),
                        ({"tle": "x" * 20000}, "at most"),
                        ({"remove": 25544}, "no satellite 25544"),
                        ({}, "give tle")):
        r = client.post(PATH, body)
        assert r.status_code in (400, 409), (body, r.status_code, r.text)
        assert words in r.json()["error"], (body, r.text)
    for query in ("hours=0", "hours=1e9", "hours=abc"):
        r = client.session.get(f"{base_url}{PATH}?{query}", timeout=10)
        assert r.status_code == 400, r.text
    r = client.post(PATH + "/follow", {"number": "ISS"})
    assert r.status_code == 400 and "whole number" in r.json()["error"]
    r = client.post(PATH + "/follow", {"stop": "yes"})
    assert r.status_code == 400


def test_follow_needs_a_connected_mount_and_a_pass_soon(live_server: object, base_url: str) -> None:
    client = Client(base_url)
    assert client.post(PATH, {"tle": ISS_TEXT}).status_code == 200
    r = client.post(PATH + "/follow", {"number": 25544})
    assert r.status_code == 409 and "not connected" in r.json()["error"]
    client.command("connected", Connected="true")
    r = client.post(PATH + "/follow", {"number": 25544})
    assert r.status_code == 409, r.text  # eight years past its epoch: refused, whatever SGP4 predicts
    assert "load a fresh set" in r.json()["error"]
    assert client.post(PATH + "/follow", {"stop": True}).status_code == 200  # nothing to stop: fine
    assert client.value("slewing") is False
