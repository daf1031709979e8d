"""Start at boot: the generated systemd unit verifies, and each definition's command really serves.

``systemd-analyze verify`` checks the unit's syntax, that ExecStart is an executable and that
its dependencies exist; a unit pointing at a missing interpreter is shown to fail it, so the
check has teeth. The command line in the unit (and in the launchd plist) is then run as written
(with a free loopback port) to show it starts this install's server.
"""

from __future__ import annotations

import plistlib
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import requests

from tests.support.emulator import OutputLines

REPO_ROOT = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "alpaca_zwo"]
LOCAL = ["--host", "127.0.0.1", "--port", "0", "--discovery-port", "0"]


def _print_service(kind: str, *args: str) -> str:
    return subprocess.run([*CLI, "--print-service", kind, *args], capture_output=True, text=True, timeout=60,
                          check=True, cwd=REPO_ROOT).stdout


def _verify(unit_text: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    analyze = shutil.which("systemd-analyze")
    if analyze is None:
        raise RuntimeError("systemd-analyze not found: apt-get install systemd (scripts/run-tests does)")
    unit = tmp_path / "alpaca-zwo.service"
    unit.write_text(unit_text)
    return subprocess.run([analyze, "verify", str(unit)], capture_output=True, text=True, timeout=60)


def _exec_start(unit_text: str) -> list[str]:
    line = next(line for line in unit_text.splitlines() if line.startswith("ExecStart="))
    return shlex.split(line.removeprefix("ExecStart="))


def _serves(cmd: list[str]) -> None:
    """Run a service's command line; it must print its URL and answer the management API."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd="/")
    try:
        assert proc.stdout is not None
        output = OutputLines(proc.stdout)  # read with a deadline: a silent child cannot hang the test
        port = int(output.expect(r"Alpaca API:\s+http://127\.0\.0\.1:(\d+)/", 30).group(1))
        assert requests.get(f"http://127.0.0.1:{port}/management/apiversions", timeout=5).json()["Value"] == [1]
    finally:
        proc.terminate()
        assert proc.wait(timeout=15) == 0


def test_systemd_unit_verifies_and_restarts_on_failure(tmp_path: Path) -> None:
    unit = _print_service("systemd", "--device", "auto", "--config", str(tmp_path / "config.toml"))
    assert "Restart=on-failure" in unit and "WantedBy=multi-user.target" in unit and "KillSignal=SIGTERM" in unit
    assert _exec_start(unit)[:3] == [str(Path(sys.executable).absolute()), "-m", "alpaca_zwo"]
    assert _exec_start(unit)[3:] == ["--config", str(tmp_path / "config.toml"), "--device", "auto"]
    verified = _verify(unit, tmp_path)
    assert verified.returncode == 0, verified.stdout + verified.stderr
    broken = unit.replace(str(Path(sys.executable).absolute()), "/nonexistent/venv/bin/python")
    assert _verify(broken, tmp_path).returncode != 0, "systemd-analyze verify accepts a missing interpreter"


def test_systemd_unit_command_starts_this_install(tmp_path: Path) -> None:
    unit = _print_service("systemd", *LOCAL, "--config", str(tmp_path / "config.toml"))
    _serves(_exec_start(unit))


def test_launchd_plist_keeps_the_server_alive(tmp_path: Path) -> None:
    plist = plistlib.loads(_print_service("launchd", *LOCAL, "--config", str(tmp_path / "c.toml")).encode())
    assert plist["RunAtLoad"] is True and plist["KeepAlive"] == {"SuccessfulExit": False}
    assert plist["Label"] == "local.alpaca-zwo"
    _serves(plist["ProgramArguments"])


@pytest.mark.parametrize("option", [[], ["--device", "auto"]])
def test_windows_task_registers_the_install_with_restarts(option: list[str]) -> None:
    text = _print_service("windows", *option)
    assert "Register-ScheduledTask -TaskName alpaca-zwo" in text and "-AtLogOn" in text
    assert "-RestartCount" in text and "[TimeSpan]::Zero" in text
    assert f"-Execute '{Path(sys.executable).absolute()}'" in text  # pythonw.exe exists only on Windows
    assert "-m alpaca_zwo --config " in text and all(word in text for word in option)
