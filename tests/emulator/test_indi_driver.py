"""A third-party driver against the emulator: INDI's ``indi_lx200am5`` (Debian ``indi-bin``).

INDI is written against real AM5 mounts, so if its driver can connect, read the position, push
time and site, GOTO, sync, abort, guide and home through the emulator, the emulator's framing
and behaviour are close enough to the real thing for a real client. The driver runs under a
real ``indiserver`` on a free loopback port, is pointed at the emulator's TCP port with
``indi_setprop`` and observed with ``indi_getprop``. Skipped where ``indi-bin`` is missing.

Waiting here is polling for an observable condition with a deadline: the driver polls the mount
once a second in real time, so nothing can be made synchronous.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from datetime import datetime, timezone
from pathlib import Path

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from tests.support import wait_until
from tests.support.indi import IndiServer


@pytest.fixture(autouse=True)
def _indi_installed() -> None:
    """scripts/run-tests installs indi-bin; a developer without it is told what is missing."""
    if shutil.which("indiserver") is None or shutil.which("indi_lx200am5") is None:
        pytest.fail("INDI is not installed: apt-get install indi-bin (scripts/run-tests does)")

SPEED = 10.0  # emulated seconds per real second: slews finish quickly, INDI polls at 1 Hz real time


@pytest.fixture
def mount_model() -> MountModel:
    return MountModel(ScaledClock(speed=SPEED))


@pytest.fixture
def emulator(mount_model: MountModel) -> Iterator[EmulatorServer]:
    server = EmulatorServer(mount_model, port=0, baud=9600).start()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def indi(tmp_path: Path, emulator: EmulatorServer) -> Iterator[IndiServer]:
    driver = IndiServer(tmp_path)
    try:
        driver.connect(emulator.port)
        yield driver
    finally:
        driver.stop()


def test_indi_lx200am5_drives_the_emulator(indi: IndiServer, emulator: EmulatorServer, mount_model: MountModel) -> None:
    model = mount_model
    # 1. It read the power-up state: home at the pole, factory site, guide rate.
    assert emulator.stats()["total"]["exchanges"] > 10
    values = indi.get("GEOGRAPHIC_COORD.*", "GUIDE_RATE.RATE", "TELESCOPE_TRACK_STATE.TRACK_OFF")
    assert float(values["GEOGRAPHIC_COORD.LAT"]) == pytest.approx(31.2614, abs=1e-3)
    assert float(values["GEOGRAPHIC_COORD.LONG"]) == pytest.approx(120.7197, abs=1e-3)  # sign handled
    assert float(values["GUIDE_RATE.RATE"]) == 0.5
    assert values["TELESCOPE_TRACK_STATE.TRACK_OFF"] == "On"
    ra, dec, _ = indi.coords()
    assert dec == 90.0
    assert sky.wrap_hours_12(ra - model.position()[0]) == pytest.approx(0.0, abs=0.01)

    # 2. Time and site: INDI negates the offset for :SG and the longitude for :Sg.
    now = datetime.now(timezone.utc)
    indi.set(f"TIME_UTC.UTC;OFFSET={now:%Y-%m-%dT%H:%M:%S};3")
    indi.set("GEOGRAPHIC_COORD.LAT;LONG;ELEV=48.1;11.5;500")
    wait_until(
        lambda: model.snapshot()["initialized"] and model.clock_site.latitude() == pytest.approx(48.1, abs=1e-3),
        20,
        "time and site to reach the mount",
    )
    assert model.clock_site.utc_offset() == 3.0
    assert model.clock_site.longitude() == pytest.approx(11.5, abs=1e-3)
    assert abs((datetime.fromisoformat(model.snapshot()["mount_utc"]) - now).total_seconds()) < 600

    # 3. GOTO (slew and track) to a point two hours east of the meridian.
    target_ra = round(sky.ra_from_hour_angle(model.clock_site.sidereal_time(), -2.0), 4)
    indi.set("ON_COORD_SET.TRACK=On")
    indi.set(f"EQUATORIAL_EOD_COORD.RA;DEC={target_ra};40")
    wait_until(model.slewing, 10, "the slew to start")
    wait_until(lambda: not model.slewing() and indi.coords()[2] == "Ok", 60, "the slew to end in INDI")
    assert sky.angular_separation(*model.position(), *model.target()) < 1 / 3600
    ra, dec, _ = indi.coords()
    assert sky.wrap_hours_12(ra - target_ra) == pytest.approx(0.0, abs=2 / 3600)
    assert dec == pytest.approx(40.0, abs=1 / 3600)
    values = indi.get("TELESCOPE_TRACK_STATE.TRACK_ON", "TELESCOPE_PIER_SIDE.PIER_WEST")
    assert values == {"TELESCOPE_TRACK_STATE.TRACK_ON": "On", "TELESCOPE_PIER_SIDE.PIER_WEST": "On"}

    # 4. Sync to a nearby position: the mount's reported coordinates jump there.
    indi.set("ON_COORD_SET.SYNC=On")
    indi.set(f"EQUATORIAL_EOD_COORD.RA;DEC={target_ra + 0.01};40.1")
    wait_until(lambda: model.snapshot()["alignment_points"] == 1, 10, "the sync")
    ra_now, dec_now = model.position()
    assert sky.angular_separation(ra_now, dec_now, *model.target()) < 1 / 3600
    assert sky.angular_separation(ra_now, dec_now, target_ra + 0.01, 40.1) < 10 / 3600  # INDI's :Sr rounding

    # 5. Guide north (INDI 1.9.9 times :RG#/:Mn#/:Qn# itself): Dec goes up about 7.5".
    dec_before = model.position()[1]
    indi.set("TELESCOPE_TIMED_GUIDE_NS.TIMED_GUIDE_N;TIMED_GUIDE_S=1000;0")
    wait_until(lambda: model.position()[1] > dec_before + 5 * SPEED / 3600, 10, "the guide pulse")

    # 6. Abort a GOTO: the slew ends short of its target.
    indi.set("ON_COORD_SET.TRACK=On")
    far_ra = round(sky.ra_from_hour_angle(model.clock_site.sidereal_time(), 3.0), 4)
    indi.set(f"EQUATORIAL_EOD_COORD.RA;DEC={far_ra};10")
    wait_until(model.slewing, 10, "the second slew to start")
    indi.set("TELESCOPE_ABORT_MOTION.ABORT=On")
    wait_until(lambda: not model.slewing(), 10, "the abort")
    assert sky.angular_separation(*model.position(), *model.target()) > 5.0

    # 7. Home: INDI waits for H in :GU#; tracking ends off, at the pole, :Gm# N.
    indi.set("GO_HOME.GO=On")
    wait_until(lambda: indi.get("GO_HOME._STATE").get("GO_HOME._STATE") == "Ok", 60, "home to finish in INDI")
    assert model.pier_letter() == "N"
    assert model.tracking_state() == (False, None)
    assert indi.get("TELESCOPE_TRACK_STATE.TRACK_OFF")["TELESCOPE_TRACK_STATE.TRACK_OFF"] == "On"
    assert indi.coords()[1] == 90.0
