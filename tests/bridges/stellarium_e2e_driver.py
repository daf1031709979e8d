"""Real Stellarium (Debian's package, under Xvfb) against alpaca-zwo's Stellarium server.

Run by tests/bridges/test_stellarium_e2e.py inside a private network namespace (only loopback
exists, so neither Stellarium nor anything else here can reach a network; RemoteControl, which
listens on every interface, is thereby confined too). It starts the server on the emulator,
Xvfb and Stellarium configured through its own files (config.ini from Stellarium's
default_cfg.ini, modules/TelescopeControl/telescopes.json), then:
  1. reads the reticle through RemoteControl and compares it with Alpaca's position in J2000;
  2. slews the mount through Alpaca and follows the reticle until it is on the new position;
  3. makes Stellarium send a goto and checks through Alpaca where the mount went;
  4. takes a screenshot.
It prints one JSON report on the last line of stdout; the test asserts on it.

Usage: python -m tests.bridges.stellarium_e2e_driver OUT_DIR
"""

from __future__ import annotations

import configparser
import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import requests

from alpaca_zwo.config.settings import SiteSettings, StellariumSettings
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.server import AlpacaZwoServer
from tests.bridges.stellarium_rig import Alpaca, reference_to_apparent, reference_to_j2000, separation_arcsec
from tests.conftest import make_settings

TELESCOPE_NAME = "ZWO AM5"
# Paris, as Stellarium's [init_location] (the default "auto" would ask an IP-geolocation service).
PARIS = SiteSettings(latitude=48.8534, longitude=2.3488, elevation=35.0)
DEFAULT_CFG = Path("/usr/share/stellarium/data/default_cfg.ini")
STARTUP_TIMEOUT_S = 180.0  # Stellarium's first start on 2 busy cores (catalogues, shaders)
FOLLOW_TIMEOUT_S = 20.0
SLEW_TIMEOUT_S = 120.0


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def poll(condition: Callable[[], Any], timeout: float, what: str, interval: float = 0.2) -> Any:
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(interval)


# --- Stellarium's files ----------------------------------------------------------------------------


def write_config(user_dir: Path, api_port: int, stellarium_port: int) -> None:
    """config.ini from Stellarium's own defaults (a file without [main] version is discarded)."""
    cfg = configparser.ConfigParser(interpolation=None, strict=False)
    cfg.optionxform = str  # keys are case-sensitive to Stellarium
    cfg.read(DEFAULT_CFG)
    plugins = cfg["plugins_load_at_startup"]
    for name in list(plugins):  # Satellites, Exoplanets etc. fetch updates: load only what is tested
        plugins[name] = "false"
    plugins["TelescopeControl"] = "true"
    plugins["RemoteControl"] = "true"
    cfg["RemoteControl"] = {"autostart": "true", "port": str(api_port), "use_password": "false",
                            "enable_cors": "false"}
    cfg["video"].update({"fullscreen": "false", "screen_w": "1280", "screen_h": "800",
                         "minimum_fps": "5", "maximum_fps": "5"})
    cfg["init_location"]["location"] = "Paris, Western Europe"
    cfg["landscape"].update({"flag_landscape": "false", "flag_atmosphere": "false", "flag_fog": "false"})
    cfg["search"]["flag_search_online"] = "false"
    cfg["astro"]["flag_toast_survey"] = "false"
    cfg["gui"]["flag_show_hips_button"] = "false"
    with (user_dir / "config.ini").open("w") as f:
        cfg.write(f)
    telescopes = {"version": "0.4.1",  # exactly the plugin's: any other value opens a modal dialog
                  "1": {"name": TELESCOPE_NAME, "connection": "remote", "equinox": "J2000",
                        "host_name": "127.0.0.1", "tcp_port": stellarium_port, "delay": 500000,
                        "connect_at_startup": True, "circles": []}}
    module_dir = user_dir / "modules" / "TelescopeControl"
    module_dir.mkdir(parents=True)
    (module_dir / "telescopes.json").write_text(json.dumps(telescopes, indent=1))


@contextmanager
def xvfb(out: Path) -> Iterator[str]:
    """A virtual display; yields its DISPLAY value."""
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-screen", "0", "1280x800x24", "-nolisten", "tcp"],
                            pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=(out / "xvfb.log").open("w"))
    os.close(write_fd)
    try:
        with os.fdopen(read_fd) as pipe:
            number = pipe.readline().strip()  # Xvfb writes it once the display accepts clients
        if not number:
            raise RuntimeError(f"Xvfb did not start: {(out / 'xvfb.log').read_text()[-500:]}")
        yield f":{number}"
    finally:
        proc.terminate()
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=10)
        if proc.poll() is None:
            proc.kill()


@contextmanager
def stellarium(out: Path, display: str, api_port: int, stellarium_port: int) -> Iterator[StellariumApi]:
    home = out / "home"
    user_dir = home / "stellarium"
    user_dir.mkdir(parents=True)
    write_config(user_dir, api_port, stellarium_port)
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "DISPLAY": display, "HOME": str(home),
           "XDG_CONFIG_HOME": str(home / ".config"), "XDG_DATA_HOME": str(home / ".local/share"),
           "XDG_CACHE_HOME": str(home / ".cache"), "XDG_RUNTIME_DIR": str(home / "run"),
           "LANG": "C.UTF-8", "QT_QPA_PLATFORM": "xcb"}
    (home / "run").mkdir(mode=0o700)
    proc = subprocess.Popen(["stellarium", "--user-dir", str(user_dir)], env=env, stdin=subprocess.DEVNULL,
                            stdout=(out / "stellarium.out").open("w"), stderr=subprocess.STDOUT)
    api = StellariumApi(api_port, user_dir / "log.txt", proc)
    try:
        yield api
    finally:
        with contextlib.suppress(requests.RequestException):
            api.script("core.quitStellarium();", timeout=5)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=15)
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=10)
        if proc.poll() is None:
            proc.kill()
            proc.wait()


class StellariumApi:
    """Stellarium's RemoteControl HTTP API and its log."""

    def __init__(self, port: int, log: Path, proc: subprocess.Popen[bytes]) -> None:
        self.base = f"http://127.0.0.1:{port}/api/"
        self.log = log
        self.proc = proc
        self.session = requests.Session()

    def alive(self) -> None:
        if self.proc.poll() is not None:
            raise RuntimeError(f"Stellarium exited with {self.proc.returncode}")

    def log_has(self, text: str) -> bool:
        self.alive()
        try:
            return text in self.log.read_text(errors="replace")
        except FileNotFoundError:
            return False

    def script(self, code: str, timeout: float = 10.0) -> str:
        reply = self.session.post(self.base + "scripts/direct", data={"code": code}, timeout=timeout)
        reply.raise_for_status()
        return reply.text

    def reticle(self) -> tuple[float, float]:
        """The telescope's J2000 RA (hours) and Dec (degrees) as Stellarium shows them."""
        self.alive()
        info = self.session.get(self.base + "objects/info", params={"name": TELESCOPE_NAME, "format": "json"},
                                timeout=10).json()
        return float(info["raJ2000"]) / 15.0, float(info["decJ2000"])


# --- the scenario ------------------------------------------------------------------------------


def _follow(api: StellariumApi, expected: tuple[float, float], tolerance: float) -> dict[str, Any]:
    """Poll the reticle until it is within tolerance (arcsec) of expected; report the track."""
    start = time.monotonic()
    track: list[tuple[float, float, float]] = []

    def there() -> bool:
        ra, dec = api.reticle()
        error = separation_arcsec(ra, dec, *expected)
        track.append((round(time.monotonic() - start, 2), ra, dec))
        return error <= tolerance

    poll(there, FOLLOW_TIMEOUT_S, "the reticle to reach the mount's position", interval=0.25)
    ra, dec = track[-1][1:]
    return {"expected": expected, "reticle": (ra, dec), "error_arcsec": separation_arcsec(ra, dec, *expected),
            "seconds": round(time.monotonic() - start, 2), "samples": len(track)}


def _j2000_now(alpaca: Alpaca) -> tuple[float, float]:
    ra, dec, when = alpaca.radec_and_time()
    return reference_to_j2000(ra, dec, when, PARIS)


def _hms(hours: float) -> str:
    total = round(hours * 36000) % (24 * 36000)  # tenths of a second of time
    return f"{total // 36000:02d}h{total // 600 % 60:02d}m{total % 600 / 10:04.1f}s"


def _dms(degrees: float) -> str:
    total = round(abs(degrees) * 3600)
    sign = "-" if degrees < 0 else "+"
    return f"{sign}{total // 3600:02d}d{total // 60 % 60:02d}m{total % 60:02d}s"


def scenario(out: Path) -> dict[str, Any]:
    report: dict[str, Any] = {}
    t0 = time.monotonic()
    settings = make_settings(site=PARIS, stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0))
    server = AlpacaZwoServer(SettingsStore(settings, out / "config.toml"))
    server.start()
    try:
        alpaca = Alpaca(server.port)
        alpaca.put("connected", Connected=True)
        alpaca.put("tracking", Tracking=True)
        api_port = free_port()
        with xvfb(out) as display, stellarium(out, display, api_port, server.stellarium.port) as api:
            lst = float(alpaca.get("siderealtime"))
            alpaca.put("slewtocoordinatesasync", RightAscension=(lst - 1.0) % 24.0, Declination=40.0)
            poll(lambda: api.log_has("Connection established"), STARTUP_TIMEOUT_S, "Stellarium to connect")
            report["connected_after_s"] = round(time.monotonic() - t0, 1)
            # A client after its opening silence (it sends nothing until a goto): QUIET_OPENING_S later.
            report["bridge_clients"] = poll(lambda: server.stellarium.status()["clients"], 10.0,
                                            "Stellarium to become the bridge's client")
            # Stellarium 0.22.2 segfaults if objects/info names a telescope that has not had its first
            # position yet; the positions flow at 4 Hz with a 0.5 s display delay, so 3 s covers it.
            time.sleep(3.0)
            poll(lambda: not alpaca.get("slewing"), SLEW_TIMEOUT_S, "the first slew to end")
            report["at_first_position"] = _follow(api, _j2000_now(alpaca), tolerance=1.0)

            lst = float(alpaca.get("siderealtime"))
            alpaca.put("slewtocoordinatesasync", RightAscension=(lst + 1.0) % 24.0, Declination=20.0)
            moving = poll(lambda: api.reticle() if separation_arcsec(*api.reticle(),
                                                                       *report["at_first_position"]["reticle"]) > 60
                          else None, FOLLOW_TIMEOUT_S, "the reticle to start moving with the mount")
            report["reticle_while_slewing"] = moving
            poll(lambda: not alpaca.get("slewing"), SLEW_TIMEOUT_S, "the Alpaca slew to end")
            report["after_alpaca_slew"] = _follow(api, _j2000_now(alpaca), tolerance=1.0)

            target = ((float(alpaca.get("siderealtime")) - 0.5) % 24.0, 55.0)
            target = (round(target[0] * 36000) / 36000, target[1])  # what the h/m/s text says exactly
            api.script(f'CustomObjectMgr.addCustomObject("T1", "{_hms(target[0])}", "{_dms(target[1])}", true);'
                       'core.selectObjectByName("T1", true); TelescopeControl.slewTelescopeToSelectedObject(1);')
            poll(lambda: server.stellarium.status()["last_command"], 10.0, "Stellarium's goto to arrive")
            poll(lambda: not alpaca.get("slewing"), SLEW_TIMEOUT_S, "Stellarium's slew to end")
            _, _, when = alpaca.radec_and_time()
            aimed = float(alpaca.get("targetrightascension")), float(alpaca.get("targetdeclination"))
            mount = alpaca.radec_and_time()[:2]
            expected_apparent = reference_to_apparent(*target, when, PARIS)
            report["stellarium_goto"] = {
                "target_j2000": target, "bridge_record": server.stellarium.status()["last_command"],
                "alpaca_target": aimed, "target_error_arcsec": separation_arcsec(*aimed, *expected_apparent),
                "mount": mount, "mount_error_arcsec": separation_arcsec(*mount, *expected_apparent),
                "reticle": _follow(api, target, tolerance=2.0)}

            api.script('StelSkyLayerMgr.setFlagShow(false); core.selectObjectByName("ZWO AM5", true);'
                       "StelMovementMgr.setFlagTracking(true); StelMovementMgr.zoomTo(6, 0);")
            time.sleep(2.0)  # let a few frames render at 5 fps before the capture
            shot = out / "stellarium-reticle.png"
            subprocess.run(["import", "-display", display, "-window", "root", str(shot)], check=True, timeout=60)
            report["screenshot"] = str(shot)
            report["bridge_status"] = server.stellarium.status()
    finally:
        server.stop()
    report["total_s"] = round(time.monotonic() - t0, 1)
    return report


def main() -> int:
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    try:
        report = scenario(out)
    except Exception as exc:  # the report carries the failure; the test shows it with the logs
        report = {"error": f"{type(exc).__name__}: {exc}"}
    print(json.dumps(report, default=str), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
