"""``--device auto`` and ``--list-devices`` against real pseudo-terminals.

Three kinds of port: the emulator's pty (a mount: answers ``:GVP#`` with ``AM5#``), a pty that
stays silent, and a pty that answers garbage. pyserial does not list ptys, so they are named with
``--probe``, which goes through the same probing as a port the OS lists. The non-mount ports must
receive exactly one ``:GVP#`` and nothing else.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import requests

from alpaca_zwo.emulator import EmulatorServer, FirmwareVariant, MountModel, ScaledClock
from tests.support.emulator import OutputLines

REPO_ROOT = Path(__file__).resolve().parents[2]
CLI = [sys.executable, "-m", "alpaca_zwo"]


@dataclass
class FakePort:
    """A pty whose far end records what it got and answers ``reply`` (or nothing) to anything."""

    reply: bytes | None
    received: bytearray = field(default_factory=bytearray)

    def __post_init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        import select

        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if not ready:
                continue
            try:
                data = os.read(self.master, 1024)
            except OSError:
                continue
            self.received += data
            if self.reply is not None:
                os.write(self.master, self.reply)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        os.close(self.master)
        os.close(self.slave)


@pytest.fixture
def ports() -> Iterator[dict[str, object]]:
    model = MountModel(ScaledClock(), FirmwareVariant(model="AM5"))
    emulator = EmulatorServer(model, port=0, baud=9600, pty=True).start()
    silent, garbage = FakePort(None), FakePort(b"\x00\xffgarbage?\r\n")
    yield {"mount": emulator.pty_path, "silent": silent, "garbage": garbage}
    emulator.stop()
    silent.close()
    garbage.close()


def _probe_args(*paths: str) -> list[str]:
    return [word for path in paths for word in ("--probe", path)]


def test_list_devices_tells_each_port_apart(ports: dict, tmp_path: Path) -> None:
    silent, garbage = ports["silent"], ports["garbage"]
    started = time.monotonic()
    done = subprocess.run([*CLI, "--list-devices", *_probe_args(ports["mount"], silent.path, garbage.path)],
                          capture_output=True, text=True, timeout=60, cwd=REPO_ROOT)
    elapsed = time.monotonic() - started
    assert done.returncode == 0, done.stderr
    lines = {line.split()[0]: line for line in done.stdout.splitlines() if line.startswith("/")}
    assert "answered :GVP# with 'AM5#': ZWO AM5" in lines[ports["mount"]]
    assert "no answer to :GVP#" in lines[silent.path] and "not a ZWO mount" in lines[silent.path]
    assert "garbage" in lines[garbage.path] and "not a ZWO mount" in lines[garbage.path]
    assert done.stdout.strip().endswith(f"mount: {ports['mount']}")
    assert bytes(silent.received) == b":GVP#" and bytes(garbage.received) == b":GVP#"  # asked once, nothing more
    assert elapsed < 10, f"probing took {elapsed:.1f} s"


def test_device_auto_finds_the_emulated_mount_and_serves_it(ports: dict, tmp_path: Path) -> None:
    silent, garbage = ports["silent"], ports["garbage"]
    proc = subprocess.Popen([*CLI, "--device", "auto", *_probe_args(silent.path, garbage.path, ports["mount"]),
                             "--host", "127.0.0.1", "--port", "0", "--discovery-port", "0",
                             "--config", str(tmp_path / "config.toml")],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=REPO_ROOT)
    try:
        assert proc.stdout is not None
        output = OutputLines(proc.stdout)  # read with a deadline: a silent child cannot hang the test
        port = int(output.expect(r"Alpaca API:\s+http://127\.0\.0\.1:(\d+)/", 30).group(1))
        assert any(f"found the mount at {ports['mount']}" in line for line in output.seen), output.seen
        base = f"http://127.0.0.1:{port}/api/v1/telescope/0"
        assert requests.put(f"{base}/connected", data={"Connected": "true"}, timeout=10).json()["ErrorNumber"] == 0
        reply = requests.get(f"{base}/declination", timeout=10).json()
        assert reply["ErrorNumber"] == 0 and -90 <= reply["Value"] <= 90
    finally:
        proc.terminate()
        proc.wait(timeout=15)


def test_device_auto_without_a_mount_lists_ports_and_says_what_to_do(ports: dict) -> None:
    silent, garbage = ports["silent"], ports["garbage"]
    done = subprocess.run([*CLI, "--device", "auto", *_probe_args(silent.path, garbage.path)],
                          capture_output=True, text=True, timeout=60, cwd=REPO_ROOT)
    assert done.returncode == 1
    message = done.stderr
    assert "no ZWO mount found" in message
    assert silent.path in message and garbage.path in message
    assert "switched on" in message and "socket://192.168.4.1:4030" in message and "--list-devices" in message


def test_missing_device_is_named_with_the_ports_seen(tmp_path: Path) -> None:
    missing = "/dev/ttyACM-not-here"
    done = subprocess.run([*CLI, "--list-devices", "--probe", missing], capture_output=True, text=True, timeout=60)
    assert f"{missing} does not exist" in done.stdout
    proc = subprocess.Popen([*CLI, "--device", missing, "--host", "127.0.0.1", "--port", "0",
                             "--discovery-port", "0", "--config", str(tmp_path / "config.toml")],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=REPO_ROOT)
    try:
        assert proc.stdout is not None
        first = proc.stdout.readline()
        assert f"{missing} does not exist (yet); ports seen:" in first
        assert "switched on" in first and "keeps trying" in first
    finally:
        proc.terminate()
        proc.wait(timeout=15)


def _as_unprivileged(fn, *args: object) -> tuple[int, str]:
    """Run ``fn(*args)`` in a child that is a non-root user (nobody) when we are root; its stderr back."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # child: drop to nobody (if root), send stderr into the pipe, report the return code
        code = 99
        try:
            os.dup2(write, 2)
            sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115 - pytest replaced sys.stderr
            if os.geteuid() == 0:
                os.setgroups([])
                os.setgid(65534)
                os.setuid(65534)
            code = fn(*args)
        except BaseException as exc:  # anything here must end the child, never return into pytest
            with contextlib.suppress(Exception):
                os.write(2, f"child failed: {exc!r}".encode())
        finally:
            with contextlib.suppress(Exception):
                sys.stderr.flush()
            os._exit(code if isinstance(code, int) else 98)
    os.close(write)
    chunks = []
    while chunk := os.read(read, 65536):
        chunks.append(chunk)
    os.close(read)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status), b"".join(chunks).decode(errors="replace")


def test_permission_denied_names_dialout_and_the_udev_rule(ports: dict, tmp_path: Path) -> None:
    """A port the user may not open (as a user outside dialout meets /dev/ttyACM0)."""
    import serial.tools.list_ports  # noqa: F401 - imported here: the unprivileged child may not read site-packages

    from alpaca_zwo.cli import server_main

    path = ports["mount"]
    os.chmod(path, 0o600 if os.geteuid() == 0 else 0o000)  # root's pty, or our own with no access
    try:
        code, stderr = _as_unprivileged(server_main, ["--device", path, "--config", str(tmp_path / "c.toml")])
        assert code == 1, stderr
        assert f"permission denied on {path}" in stderr
        assert "dialout" in stderr and "log out and in" in stderr and "99-zwo-mount.rules" in stderr
        code, stderr = _as_unprivileged(server_main, ["--device", "auto", "--probe", path])
        assert code == 1 and "no ZWO mount found" in stderr, stderr
        assert f"permission denied on {path}" in stderr and "dialout" in stderr
    finally:
        os.chmod(path, 0o620)


def test_busy_port_says_another_program_has_it(ports: dict) -> None:
    """A port another program holds exclusively (as a driver holds the mount's port)."""
    import serial

    holder = serial.Serial(ports["mount"], exclusive=True)
    try:
        done = subprocess.run([*CLI, "--device", "auto", "--probe", ports["mount"]], capture_output=True, text=True,
                              timeout=60, cwd=REPO_ROOT)
        assert done.returncode == 1
        assert "is busy" in done.stderr and "ZWO app" in done.stderr and "ASIAIR" in done.stderr
    finally:
        holder.close()


def _port_info(device: str, vid: int | None, pid: int | None, description: str = "n/a"):
    from serial.tools.list_ports_common import ListPortInfo

    info = ListPortInfo(device, skip_link_detection=True)
    info.vid, info.pid, info.description = vid, pid, description
    return info


def test_usb_ids_pick_the_mount_and_other_devices_are_never_opened(ports: dict, monkeypatch) -> None:
    """The USB-ID path, with pyserial's listing replaced (no USB hardware here) by what it reports
    for a ZWO mount (03c3:4001, here the emulator's pty) and for an Arduino-like device (2341:0043,
    here the silent pty): the mount is chosen and confirmed by asking it, the other is not touched."""
    from serial.tools import list_ports

    from alpaca_zwo.zwo import devices

    silent = ports["silent"]
    listed = [_port_info(ports["mount"], 0x03C3, 0x4001, "ZWO AM5"),
              _port_info(silent.path, 0x2341, 0x0043, "Arduino Uno")]
    monkeypatch.setattr(list_ports, "comports", lambda *a, **k: listed)
    candidates = {c.device: c for c in devices.list_candidates()}
    assert candidates[ports["mount"]].zwo_usb and candidates[ports["mount"]].model == "AM5"
    assert "another USB device: Arduino Uno" in candidates[silent.path].what
    assert candidates[silent.path].answer == "not asked"
    assert devices.find_mount() == ports["mount"]
    assert bytes(silent.received) == b"", "a port identified as another device was opened and written to"
    table = devices.format_candidates(list(candidates.values()))
    assert "USB 03c3:4001, ZWO mount on USB (ZWO AM5); answered :GVP# with 'AM5#'" in table
    assert "USB 2341:0043, another USB device: Arduino Uno (not asked)" in table


@pytest.mark.parametrize("model", ["AM5N", "AM5X"])
def test_a_model_name_with_a_suffix_is_a_zwo_mount(model: str) -> None:
    """Any ``AM<digit>`` with a suffix is a ZWO mount (issue 39: ``:GVP#`` is ``AM5N#`` on the AM5N)."""
    port = FakePort(f"{model}#".encode())
    try:
        done = subprocess.run([*CLI, "--list-devices", *_probe_args(port.path)],
                              capture_output=True, text=True, timeout=60, cwd=REPO_ROOT)
    finally:
        port.close()
    assert done.returncode == 0, done.stderr
    assert f"answered :GVP# with '{model}#': ZWO {model}" in done.stdout
    assert bytes(port.received) == b":GVP#"
