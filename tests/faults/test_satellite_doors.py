"""A satellite's follow seen from the doors (issue 41), through the real HTTP server and the emulator: another
client's slews, moves, guide pulses and rate offsets are refused with the ASCOM error and words naming the pass,
Slewing reads true while RA/Dec move with the satellite, and the observatory interlock (an unsafe
SafetyMonitor, alpaca-simulators as in test_observatory.py) ends the follow at once and parks the mount, as it
does any other motion. The follow's accuracy is judged on the emulator in tests/motion/test_satellite_follow.py.

The mount's universe starts shortly before a pass of the shipped ISS elements (2018), and the server takes the
mount's clock (``time.source = "mount"``), as in the field with no network.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import pytest

from alpaca_zwo.config.settings import TimeSettings
from alpaca_zwo.sky import SIDEREAL_DEG_S
from alpaca_zwo.telescope.orbits import parse_tles
from alpaca_zwo.telescope.passes import AllowedSky, Pass, passes
from tests.conftest import make_settings
from tests.faults.conftest import Rig, RigFactory
from tests.faults.test_observatory import INVALID_OPERATION, interlock, still, wait_state
from tests.support import AlpacaClient, wait_until
from tests.support.observatory import AlpacaSimulators

ISS_TEXT = (Path(__file__).parents[1] / "support" / "tle" / "iss-2018-05-15.tle").read_text(encoding="utf-8")
ISS = parse_tles(ISS_TEXT)[0]
#: The words every refusal during the follow carries (``MotionSupervisor._refuse_during_follow``).
NAMES_THE_PASS = "the mount is following ISS (ZARYA)'s pass"


@pytest.fixture
def sims(tmp_path: Path) -> Iterator[AlpacaSimulators]:
    with AlpacaSimulators(tmp_path) as simulators:
        yield simulators


def _low_pass() -> Pass:
    """A low pass one pier side follows whole: its follow is short and needs no flip."""
    found = passes(ISS, AllowedSky(make_settings(), None), ISS.epoch, hours=24.0, limit=50)
    return next(p for p in found if 5.0 < p.max_altitude < 15.0 and p.side.until is None)


def _track(client: AlpacaClient, parameters: dict[str, Any] | None = None) -> dict[str, Any]:
    raw = "" if parameters is None else json.dumps(parameters)
    reply: dict[str, Any] = json.loads(client.command("action", Action="zwo:TrackSatellite", Parameters=raw).value)
    return reply


def _following(rig_factory: RigFactory, **sections: Any) -> tuple[Rig, AlpacaClient]:
    """A server whose mount's universe starts 30 s before a low pass, following it (the main client's
    zwo:TrackSatellite), its GOTO to the entry point under way."""
    chosen = _low_pass()
    rig = rig_factory(start_utc=chosen.enters - timedelta(seconds=30), time=TimeSettings(source="mount"), **sections)
    main = rig.clients[0]
    assert abs((rig.telescope.mount.time.now() - rig.truth()).total_seconds()) < 2.0  # the mount's clock
    main.command("tracking", Tracking=True)
    _track(main, {"tle": ISS_TEXT})
    assert _track(main)["following"] is True
    return rig, main


def _wait_phase(client: AlpacaClient, phase: str, timeout: float) -> dict[str, Any]:
    return wait_until(lambda: (r := _track(client)).get("phase") == phase and r, timeout, f"the follow {phase}",
                      interval=0.2)


def test_other_clients_are_refused_with_the_pass_named_and_slewing_tells_the_truth(rig_factory: RigFactory) -> None:
    rig, main = _following(rig_factory)
    other = rig.client(777)
    other.command("connected", Connected="true")
    ra = other.value("siderealtime")
    for member, params in (("slewtocoordinatesasync", {"RightAscension": (ra + 3.0) % 24.0, "Declination": 20.0}),
                           ("moveaxis", {"Axis": 0, "Rate": 1.0}),
                           ("pulseguide", {"Direction": 0, "Duration": 500}),
                           ("rightascensionrate", {"RightAscensionRate": 0.01})):
        call = other.put(member, **params)
        assert call.error_number == INVALID_OPERATION, (member, call)
        assert NAMES_THE_PASS in call.error_message and "zwo:TrackSatellite stop" in call.error_message, call
    assert other.value("rightascensionrate") == 0.0
    _wait_phase(main, "following", timeout=60.0)
    # While it follows, a client that polls sees the truth: Slewing true, RA/Dec moving with the satellite
    # (far faster than the sky turns: a low ISS pass sweeps degrees a minute).
    samples = []
    started = time.monotonic()
    for _ in range(10):
        samples.append((other.value("slewing"), other.value("rightascension"), other.value("declination")))
        time.sleep(0.3)  # the poll interval of a client, not a wait for anything
    elapsed = time.monotonic() - started
    assert all(slewing is True for slewing, _, _ in samples), samples
    (_, ra0, dec0), (_, ra1, dec1) = samples[0], samples[-1]
    moved_deg = math.hypot((ra1 - ra0) * 15.0 * math.cos(math.radians(dec0)), dec1 - dec0)
    assert moved_deg > 10.0 * SIDEREAL_DEG_S * elapsed, samples  # the sky alone would turn it a tenth of this
    assert rig.snapshot()["moves_deg_s"] != [None, None]  # the emulator's truth: its axes are being driven
    other.command("abortslew")
    assert _track(main)["ended"] == "stopped"
    wait_until(lambda: main.value("slewing") is False, 15.0, "the mount at rest")
    assert rig.snapshot()["moves_deg_s"] == [None, None] and rig.snapshot()["slew"] is None


def test_the_interlock_ends_a_follow_at_once_and_parks(rig_factory: RigFactory, sims: AlpacaSimulators) -> None:
    rig, main = _following(rig_factory, safety=interlock(sims))
    wait_state(main, "safe")
    _wait_phase(main, "following", timeout=60.0)
    assert rig.snapshot()["moves_deg_s"] != [None, None]
    sims.set_safe(False)
    ended = wait_until(lambda: (r := _track(main))["phase"] == "ended" and r, 5.0, "the follow to end", interval=0.05)
    # The interlock stops the mount (as any motion: :Q#), then parks it.
    assert ended["following"] is False and ended["ended"] in ("stopped", "replaced by a park"), ended
    assert rig.snapshot()["moves_deg_s"] == [None, None]
    wait_until(lambda: main.value("atpark") is True, 90.0, "the server to park the mount")
    assert still(rig) and rig.snapshot()["at_home"], rig.snapshot()
    assert main.value("slewing") is False
    call = main.put("action", Action="zwo:TrackSatellite", Parameters=json.dumps({"tle": ISS_TEXT}))
    assert call.error_number == INVALID_OPERATION and "parked" in call.error_message, call
