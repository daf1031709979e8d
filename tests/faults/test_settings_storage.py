"""A settings save that the disk refuses: every saving setter answers a clear error and changes nothing.

The server's settings file sits on storage that fails in three real ways: its folder replaced by a
plain file (works for any user: ``NotADirectoryError``-like, no privilege needed), a full tmpfs
(``ENOSPC``) and a tmpfs remounted read-only (``EROFS``: unlike ``chmod``, this stops root too). The
last two need ``mount`` and are skipped where it is not allowed.

For every Alpaca member and setup-API route that saves, the reply must be HTTP 200 with DriverError
0x510 (Alpaca) or HTTP 507 with that number (setup API), say that nothing was changed, and carry no
file path; the values clients read, the mount's own settings (the emulator's truth) and the bytes of
the file must all be as before. Once the storage works again, the same change is saved.
"""

from __future__ import annotations

import errno
import os
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import requests

from alpaca_zwo._exceptions import ERR_SETTINGS_NOT_SAVED
from alpaca_zwo.config.settings import ZwoPortSettings
from alpaca_zwo.web import CSRF_HEADER
from tests.conftest import ServerFactory, make_settings
from tests.support import AlpacaClient

HEADERS = {CSRF_HEADER: "1", "Content-Type": "application/json"}
TIMEOUT = 10.0
CLIENT_ID = 5150


def _mount_tmpfs(where: Path, size: str) -> bool:
    where.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                          capture_output=True, check=False)
    return done.returncode == 0


def _umount(where: Path) -> None:
    subprocess.run(["umount", "-l", str(where)], capture_output=True, check=False)


class Storage:
    """The config folder ``root/cfg`` and a way to make it refuse writes, then work again."""

    def __init__(self, root: Path, kind: str) -> None:
        self.root = root
        self.kind = kind
        self.folder = root / "cfg"
        self.mounted = False

    def prepare(self) -> None:
        if self.kind in ("full-disk", "read-only"):
            if not _mount_tmpfs(self.folder, "256k"):
                pytest.skip("mount -t tmpfs is not allowed here")
            self.mounted = True

    @property
    def config(self) -> Path:
        """Where the server's file is (its bytes, for comparing)."""
        if self.kind == "folder-is-a-file" and self.folder.is_file():
            return self.root / "cfg.real" / "config.toml"
        return self.folder / "config.toml"

    def break_it(self) -> None:
        if self.kind == "folder-is-a-file":
            self.folder.rename(self.root / "cfg.real")
            self.folder.write_text("a file where the settings folder was\n")
        elif self.kind == "full-disk":
            fd = os.open(self.folder / "filler", os.O_WRONLY | os.O_CREAT, 0o600)
            try:
                while True:
                    os.write(fd, b"\0" * 512)
            except OSError as exc:
                assert exc.errno == errno.ENOSPC, exc
            finally:
                os.close(fd)
        else:
            subprocess.run(["mount", "-o", "remount,ro", str(self.folder)], check=True)

    def mend(self) -> None:
        if self.kind == "folder-is-a-file":
            self.folder.unlink()
            (self.root / "cfg.real").rename(self.folder)
        elif self.kind == "full-disk":
            (self.folder / "filler").unlink()
        else:
            subprocess.run(["mount", "-o", "remount,rw", str(self.folder)], check=True)

    def close(self) -> None:
        if self.mounted:
            _umount(self.folder)


@pytest.fixture(params=["folder-is-a-file", "full-disk", "read-only"])
def storage(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Storage]:
    store = Storage(tmp_path, request.param)
    store.prepare()
    try:
        yield store
    finally:
        store.close()


class Rig:
    def __init__(self, port: int) -> None:
        self.base = f"http://127.0.0.1:{port}"
        self.client = AlpacaClient(port, CLIENT_ID, timeout=TIMEOUT)
        self.session = requests.Session()

    def post(self, path: str, body: object) -> requests.Response:
        return self.session.post(f"{self.base}/setup/api{path}", json=body, headers=HEADERS, timeout=TIMEOUT)

    def action(self, name: str, parameters: str) -> requests.Response:
        return self.client.http_put("action", {"Action": name, "Parameters": parameters, "ClientID": CLIENT_ID})

    def put(self, member: str, **fields: Any) -> requests.Response:
        return self.client.http_put(member, {**fields, "ClientID": CLIENT_ID})


#: Each saving route: (name, request). Alpaca ones must answer 200 + 0x510, setup ones 507 + 0x510.
ALPACA: list[tuple[str, Callable[[Rig], requests.Response]]] = [
    ("SiteLatitude", lambda r: r.put("sitelatitude", SiteLatitude="12.5")),
    ("SiteLongitude", lambda r: r.put("sitelongitude", SiteLongitude="7.25")),
    ("SiteElevation", lambda r: r.put("siteelevation", SiteElevation="321")),
    ("SetPark", lambda r: r.put("setpark")),
    ("zwo:Horizon", lambda r: r.action("zwo:Horizon", '{"min_altitude_deg": 7, "horizon": [[0, 12]]}')),
    ("zwo:MeridianSettings", lambda r: r.action("zwo:MeridianSettings", '{"limit_degrees": 9, "track_past": true}')),
]
SETUP: list[tuple[str, Callable[[Rig], requests.Response]]] = [
    ("settings site", lambda r: r.post("/telescope/0/settings", {"site": {"latitude": 12.5, "elevation": 321}})),
    ("settings limits", lambda r: r.post("/telescope/0/settings", {"limits": {"min_altitude_deg": 7}})),
    ("settings meridian", lambda r: r.post("/telescope/0/settings",
                                           {"meridian": {"track_after": True, "limit_degrees": 9}})),
    ("settings device name", lambda r: r.post("/telescope/0/settings", {"device": {"name": "Renamed"}})),
    ("server", lambda r: r.post("/server", {"location": "elsewhere"})),
    ("action set_park", lambda r: r.post("/telescope/0/action/set_park", {})),
]


def _observed(rig: Rig, emulator_snapshot: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    """What clients read and what the mount holds: none of it may change on a failed save."""
    settings = rig.session.get(f"{rig.base}/setup/api/telescope/0/settings", timeout=TIMEOUT).json()
    server = rig.session.get(f"{rig.base}/setup/api/server", timeout=TIMEOUT).json()
    horizon = rig.action("zwo:Horizon", "").json()["Value"]
    meridian = rig.action("zwo:MeridianSettings", "").json()["Value"]
    truth = emulator_snapshot()
    return {
        "alpaca site": [rig.client.value(m) for m in ("sitelatitude", "sitelongitude", "siteelevation")],
        "page": {k: settings[k] for k in ("site", "park", "limits", "device")},
        "server location": server["location"],
        "zwo:Horizon": horizon, "zwo:MeridianSettings": meridian,
        "mount site": (truth["latitude"], truth["longitude_east"]),
        "mount meridian": truth["meridian"],
    }


def test_a_failed_save_changes_nothing_and_says_so(server_factory: ServerFactory, storage: Storage) -> None:
    server = server_factory(config_name="cfg/config.toml")
    rig = Rig(server.port)
    rig.client.command("connected", Connected="true")
    rig.client.command("siteelevation", SiteElevation="46.5")  # the file exists and works
    model = server.emulators[0].server.model  # type: ignore[union-attr]
    before = _observed(rig, model.snapshot)
    file_before = storage.config.read_bytes()

    storage.break_it()
    problems: list[str] = []
    for name, send in ALPACA + SETUP:
        reply = send(rig)
        body = reply.json()
        expected_status = 200 if (name, send) in ALPACA else 507
        number = body.get("ErrorNumber", body.get("number"))
        message = body.get("ErrorMessage", body.get("error", ""))
        if reply.status_code != expected_status or number != ERR_SETTINGS_NOT_SAVED:
            problems.append(f"{name}: HTTP {reply.status_code} {reply.text[:200]}")
        if "could not be saved" not in message or "nothing was changed" not in message:
            problems.append(f"{name}: unclear message {message!r}")
        if str(storage.root) in reply.text or "config.toml" in reply.text or "Traceback" in reply.text:
            problems.append(f"{name}: the reply shows a path or a traceback: {reply.text[:200]}")
    assert not problems, "\n".join(problems)
    assert _observed(rig, model.snapshot) == before
    assert storage.config.read_bytes() == file_before
    assert not [p.name for p in storage.config.parent.iterdir() if p.name.endswith(".tmp")]

    storage.mend()  # the same change now goes through, to the file too
    assert rig.put("siteelevation", SiteElevation="321").json()["ErrorNumber"] == 0
    assert "elevation = 321" in storage.config.read_text()


def test_the_log_keeps_the_path(server_factory: ServerFactory, tmp_path: Path,
                                caplog: pytest.LogCaptureFixture) -> None:
    """The reply drops the path; the server log is where the administrator finds which file failed."""
    (tmp_path / "cfg").write_text("not a folder\n")
    server = server_factory(config_name="cfg/config.toml")
    rig = Rig(server.port)
    with caplog.at_level("ERROR", logger="alpaca_zwo.config.store"):
        body = rig.put("siteelevation", SiteElevation="10").json()
    assert body["ErrorNumber"] == ERR_SETTINGS_NOT_SAVED and str(tmp_path) not in body["ErrorMessage"]
    assert any(str(tmp_path / "cfg" / "config.toml") in r.getMessage() for r in caplog.records)



def test_a_mount_that_fails_after_the_save_gets_the_file_put_back(rig_factory: Any, tmp_path: Path) -> None:
    """The other half of the order "file first, then the mount": when the mount cannot take a change
    that was already saved (here its WiFi is gone), the file is put back, so the file, the server's
    settings and the mount (the emulator's truth) still agree. A regression guard for the new order
    (the old code set the mount first)."""
    rig = rig_factory()
    client = rig.client(CLIENT_ID)
    client.command("siteelevation", SiteElevation="46.5")  # the file exists
    config = tmp_path / "config.toml"
    file_before = config.read_bytes()
    limits_before = rig.telescope.settings.limits
    mount_before = rig.snapshot()["meridian"]
    session = requests.Session()

    rig.faults.outage(30.0)
    call = client.put("action", Action="zwo:MeridianSettings", Parameters='{"limit_degrees": 9, "track_past": true}')
    assert call.status == 200 and call.error_number is not None and 0x500 <= call.error_number < 0x510, call.describe()
    change = {"meridian": {"track_after": True, "limit_degrees": 9}, "limits": {"min_altitude_deg": 7}}
    reply = session.post(f"http://127.0.0.1:{rig.port}/setup/api/telescope/0/settings", json=change,
                         headers=HEADERS, timeout=TIMEOUT)
    assert reply.status_code == 409, reply.text  # the mount's state, not the storage
    assert config.read_bytes() == file_before
    assert rig.telescope.settings.limits == limits_before
    rig.faults.clear()
    assert rig.snapshot()["meridian"] == mount_before


def test_zwo_port_site_setters_are_refused_when_the_save_fails(server_factory: ServerFactory, tmp_path: Path) -> None:
    """INDI sets the site through the shared ZWO port (``:St``/``:Sg``): a site that cannot be saved is
    refused with the mount's ``0`` and the site stays as it was (before: no reply at all, a traceback
    in the log)."""
    from tests.support.zwo_client import ZwoClient

    settings = make_settings(zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0))
    server = server_factory(settings, config_name="cfg/config.toml")
    client = AlpacaClient(server.port, CLIENT_ID, timeout=TIMEOUT)
    client.command("connected", Connected="true")
    client.command("siteelevation", SiteElevation="46.5")  # the file and its folder exist
    assert server.zwo_port is not None
    zwo = ZwoClient(server.zwo_port.port)
    try:
        storage = Storage(tmp_path, "folder-is-a-file")
        storage.break_it()
        before = client.value("sitelatitude"), client.value("sitelongitude")
        assert zwo.ask(":St+48*06:00#") == b"0"
        assert zwo.ask(":Sg-011*30:00#") == b"0"
        assert (client.value("sitelatitude"), client.value("sitelongitude")) == before
        storage.mend()
        assert zwo.ask(":St+48*06:00#") == b"1"
    finally:
        zwo.close()
