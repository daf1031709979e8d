"""The default path runs on an interpreter without fcntl, termios, tty and pty (as on Windows).

Each check runs in a fresh interpreter whose ``sitecustomize`` makes those four modules
unimportable *for alpaca_zwo*: any ``import`` of them from an ``alpaca_zwo`` module raises
ModuleNotFoundError, as on Windows. pyserial itself keeps its POSIX backend (on Windows it uses
its win32 one), so only our own code is held to the rule. The blocker is checked to bite first.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import requests
from alpaca.telescope import Telescope, TelescopeAxes

REPO_ROOT = Path(__file__).resolve().parents[2]
BLOCKED = ("fcntl", "termios", "tty", "pty")
POSIX_ONLY_MODULES: set[str] = set()  # modules allowed to need them (none: the pty is imported on demand)

BLOCKER = f'''
import builtins, importlib, sys
_BLOCKED = {BLOCKED!r}
_real_import = builtins.__import__
_real_import_module = importlib.import_module

def _refuse(name, importer):
    if name.split(".")[0] in _BLOCKED and str(importer).startswith("alpaca_zwo"):
        raise ModuleNotFoundError(f"No module named {{name!r}} (blocked: not on Windows)", name=name)

def _import(name, globals=None, locals=None, fromlist=(), level=0):
    if level == 0:
        _refuse(name, (globals or {{}}).get("__name__", ""))
    return _real_import(name, globals, locals, fromlist, level)

def _import_module(name, package=None):
    _refuse(name, sys._getframe(1).f_globals.get("__name__", ""))
    return _real_import_module(name, package)

builtins.__import__ = _import
importlib.import_module = _import_module
'''

AUDIT = '''
import json, pkgutil, traceback, alpaca_zwo
result = {}
for info in pkgutil.walk_packages(alpaca_zwo.__path__, "alpaca_zwo."):
    if info.name.endswith("__main__"):
        continue  # running the program is not importing it; the server test below runs it
    try:
        __import__(info.name)
        result[info.name] = "ok"
    except Exception as exc:
        result[info.name] = f"{type(exc).__name__}: {exc}"
probe = {}
try:
    exec("import fcntl", {"__name__": "alpaca_zwo.blocker_check"})
    probe["blocker"] = "did not block"
except ModuleNotFoundError:
    probe["blocker"] = "blocks"
from alpaca_zwo.emulator.server import pty_support_error
probe["pty_support_error"] = pty_support_error()
print(json.dumps({"modules": result, "probe": probe}))
'''


@pytest.fixture
def blocked_env(tmp_path: Path) -> dict[str, str]:
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(BLOCKER)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site), str(REPO_ROOT)])
    env.pop("PYTHONSTARTUP", None)
    return env


def test_every_module_imports_without_posix_modules(blocked_env: dict[str, str]) -> None:
    done = subprocess.run([sys.executable, "-c", AUDIT], env=blocked_env, capture_output=True, text=True,
                          timeout=120, check=True, cwd=REPO_ROOT)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["probe"]["blocker"] == "blocks"
    assert "POSIX" in (report["probe"]["pty_support_error"] or "")  # the pty knows it cannot work here
    modules = report["modules"]
    assert len(modules) > 20 and "alpaca_zwo.emulator.server" in modules and "alpaca_zwo.zwo.devices" in modules
    failed = {name: why for name, why in modules.items() if why != "ok" and name not in POSIX_ONLY_MODULES}
    assert failed == {}


def _start(cmd: list[str], env: dict[str, str]) -> subprocess.Popen[str]:
    return subprocess.Popen(cmd, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)


def _wait_for_port(proc: subprocess.Popen[str], timeout: float = 30.0) -> int:
    deadline = time.monotonic() + timeout
    seen = []
    assert proc.stdout is not None
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        seen.append(line)
        if "Alpaca API:" in line:
            return int(line.split("http://127.0.0.1:")[1].split("/")[0])
    proc.kill()
    raise AssertionError("server did not start:\n" + "".join(seen))


SERVER = [sys.executable, "-c", "import sys; from alpaca_zwo.cli import server_main; sys.exit(server_main())"]


def test_default_server_serves_a_client_and_stops_on_ctrl_c(blocked_env: dict[str, str], tmp_path: Path) -> None:
    """No --device: the built-in emulator over its loopback socket; Ctrl-C (SIGINT) stops it, exit 0."""
    proc = _start([*SERVER, "--host", "127.0.0.1", "--port", "0", "--discovery-port", "0",
                   "--config", str(tmp_path / "config.toml")], blocked_env)
    try:
        port = _wait_for_port(proc)
        versions = requests.get(f"http://127.0.0.1:{port}/management/apiversions", timeout=5).json()
        assert versions["Value"] == [1]
        scope = Telescope(f"127.0.0.1:{port}", 0)
        scope.Connected = True
        assert scope.Connected
        assert 0.0 <= scope.RightAscension < 24.0 and -90.0 <= scope.Declination <= 90.0
        scope.Tracking = True
        target = (scope.SiderealTime + 1.0) % 24.0
        scope.SlewToCoordinatesAsync(target, 30.0)
        deadline = time.monotonic() + 60
        while scope.Slewing and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not scope.Slewing
        assert abs(scope.Declination - 30.0) < 0.01
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=15) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _emulator_state(control_port: int) -> dict:
    import socket

    with socket.create_connection(("127.0.0.1", control_port), timeout=5) as sock:
        sock.sendall(b"state\n")
        data = b""
        while not data.endswith(b"\n"):
            chunk = sock.recv(65536)
            if not chunk:
                break
            data += chunk
    return json.loads(data)["state"]


def test_shutdown_stops_manual_motion_without_posix_modules(blocked_env: dict[str, str], tmp_path: Path) -> None:
    """The stop-on-shutdown safety on the Windows-like interpreter: a MoveAxis is stopped by Ctrl-C."""
    emulator = _start([sys.executable, "-m", "alpaca_zwo.emulator", "--port", "0", "--baud", "0",
                       "--control-port", "0", "--initialized"], dict(os.environ))
    proc = None
    try:
        assert emulator.stdout is not None
        lines = [emulator.stdout.readline() for _ in range(3)]
        tcp = next(line.split()[1] for line in lines if line.startswith("tcp "))
        control = int(next(line.split(":")[1] for line in lines if line.startswith("control ")))
        proc = _start([*SERVER, "--host", "127.0.0.1", "--port", "0", "--discovery-port", "0",
                       "--device", f"socket://{tcp}", "--config", str(tmp_path / "config.toml")], blocked_env)
        port = _wait_for_port(proc)
        scope = Telescope(f"127.0.0.1:{port}", 0)
        scope.Connected = True
        scope.MoveAxis(TelescopeAxes.axisPrimary, 2.0)
        deadline = time.monotonic() + 10
        while abs(_emulator_state(control)["velocity_deg_s"][0]) < 1.0 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert abs(_emulator_state(control)["velocity_deg_s"][0]) >= 1.0, "the axis never started moving"
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=15) == 0
        deadline = time.monotonic() + 10  # the mount decelerates after the stop command
        while abs(_emulator_state(control)["velocity_deg_s"][0]) > 0.01 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert abs(_emulator_state(control)["velocity_deg_s"][0]) <= 0.01, "shutdown left the axis moving"
    finally:
        for p in (proc, emulator):
            if p is not None and p.poll() is None:
                p.terminate()
                p.wait(timeout=10)


def test_emulator_pty_refused_clearly_without_posix_modules(blocked_env: dict[str, str]) -> None:
    done = subprocess.run([sys.executable, "-m", "alpaca_zwo.emulator", "--port", "0", "--pty"], env=blocked_env,
                          capture_output=True, text=True, timeout=60, cwd=REPO_ROOT)
    assert done.returncode == 2
    assert "--pty" in done.stderr and "POSIX" in done.stderr and "TCP port" in done.stderr
