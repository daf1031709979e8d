"""The ``alpaca-zwo-emulator`` command, run as a real subprocess and driven over TCP."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.emulator.emuclient import MountClient
from tests.support import EmulatorProcess

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def start_emulator() -> Iterator[type[EmulatorProcess]]:
    started: list[EmulatorProcess] = []

    class Tracked(EmulatorProcess):
        def __init__(self, *args: str) -> None:
            super().__init__(*args)
            started.append(self)

    yield Tracked
    for emulator in started:
        if emulator.proc.poll() is None:
            emulator.proc.kill()
            emulator.proc.wait(5.0)


def test_cli_serves_tcp_and_control_and_stops_cleanly(start_emulator: type[EmulatorProcess]) -> None:
    emulator = start_emulator(
        "--control-port",
        "0",
        "--baud",
        "0",
        "--initialized",
        "--start-time",
        "2025-03-20T14:00:00Z",
        "--speed",
        "2",
        "--latitude",
        "52.5",
        "--longitude",
        "13.4",
        "--model",
        "AM3",
        "--firmware",
        "1.6.3",
        "--gt-mapping",
        "chinese",
        "--hp-reply",
        "1#",
        "--home-flag",
        "always_at_home",
    )
    client = MountClient(emulator.port())
    try:
        assert client.ask(":GVP#") == "AM3#"
        assert client.ask(":GV#") == "1.6.3#"
        assert client.ask(":GC#") == "03/20/25#"  # --initialized: date set from --start-time
        assert client.ask(":Gt#") == "+52*30:00#"
        assert client.ask(":Gg#") == "-013*24:00#"  # east stored negative
        assert client.ask(":GU#") == "nNHG000000000#"
        assert client.exact(":TL#") == ""
        assert client.ask(":GT#") == "1#"
        assert client.exact(":Sr10:00:00#:Sd+45*00:00#") == "11"

        state = emulator.control("state")
        assert state["ok"] is True
        assert state["state"]["firmware"]["model"] == "AM3"  # type: ignore[index]
        assert state["state"]["initialized"] is True  # type: ignore[index]

        assert emulator.control("drop 1") == {"ok": True, "command": "drop"}
        client.assert_silent(":GVP#")
        assert client.ask(":GVP#") == "AM3#"

        stats = emulator.control("stats")["stats"]
        assert stats["total"]["exchanges"] >= 10  # type: ignore[index]

        assert emulator.control("bogus")["ok"] is False
        assert emulator.control("stall x")["ok"] is False
        assert emulator.control("reboot 0")["ok"] is True
    finally:
        client.close()
    again = MountClient(emulator.port())
    try:
        assert again.ask(":GC#") == "01/01/00#"  # rebooted through the control port
    finally:
        again.close()
    assert emulator.terminate() == 0


def test_cli_preset_sets_model_version_and_quirks(start_emulator: type[EmulatorProcess]) -> None:
    emulator = start_emulator("--baud", "0", "--preset", "am5-x2", "--firmware", "1.9.9")
    client = MountClient(emulator.port())
    try:
        assert client.ask(":GVP#") == "AM5#"
        assert client.ask(":GV#") == "1.9.9#"  # an option overrides the preset's own value
        assert client.ask(":Gps#") == "#"  # the preset's quirks: :Gps# empty, H at power-up
        assert "H" in client.ask(":GU#")
    finally:
        client.close()
    assert emulator.terminate() == 0


def test_cli_1_8_8_switches_override_a_preset(start_emulator: type[EmulatorProcess]) -> None:
    """The 1.8.8 preset with one switch turned back: the others keep answering as recorded."""
    emulator = start_emulator("--baud", "0", "--preset", "am5n-1.8.8", "--home-reading", "documents",
                              "--unknown-query", "silent")
    client = MountClient(emulator.port(), compile_time="14:01:29")
    try:
        assert client.ask(":GVP#") == "AM5N#"
        assert client.ask(":Gm#") == "N#"  # --home-reading documents
        assert client.exact(":GW#") == ""  # --unknown-query silent
        assert client.ask(":GU#") == "nNGM000000000#"  # the preset's status word is kept
    finally:
        client.close()
    assert emulator.terminate() == 0


def test_cli_pty_option_prints_a_usable_device(start_emulator: type[EmulatorProcess]) -> None:
    serial = pytest.importorskip("serial")
    emulator = start_emulator("--pty", "--baud", "0")
    path = emulator.endpoints["pty"]
    with serial.Serial(path, 9600, timeout=3.0) as port:
        port.write(b":GVP#")
        assert port.read_until(b"#") == b"AM5#"
    assert emulator.terminate() == 0


def test_cli_rejects_bad_arguments() -> None:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    result = subprocess.run(
        [sys.executable, "-m", "alpaca_zwo.emulator", "--home-flag", "sometimes"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=30,
    )
    assert result.returncode == 2
    assert "--home-flag" in result.stderr


def test_cli_pointing_errors_reach_the_mount_and_its_truth(start_emulator: type[EmulatorProcess]) -> None:
    """``--pointing-errors``/``--pointing-noise`` (docs/pointing-errors.md): the readings stay the axes', the
    control port's state says where the tube truly points (IH=30 alone: 30′ west of home's hour angle)."""
    emulator = start_emulator("--control-port", "0", "--baud", "0", "--initialized", "--latitude", "52.5",
                              "--pointing-errors", "IH=30", "--pointing-noise", "0", "--pointing-seed", "4")
    assert emulator.control("pointing")["pointing"] == {"terms_arcmin": {"IH": 30.0}, "noise_arcsec": 0.0, "seed": 4}
    state = emulator.control("state")["state"]
    assert state["dec_deg"] == 90.0  # at home: the axes' own pole
    assert abs(state["sky_dec_deg"] - 90.0) < 1e-9  # IH turns about the pole: still on it
    assert emulator.control("pointing-errors ID=6")["ok"] is True
    state = emulator.control("state")["state"]
    assert abs(state["sky_dec_deg"] - (90.0 - 0.1)) < 1e-9  # sky = axes - (-ID) past the pole: 6′ from it
    assert emulator.terminate() == 0
