"""The shared ZWO port's backend (``bridges/zwo_backend.py``) under ``zwo/dispatch.py``'s one table, on a
real Telescope driving the emulator over a loopback link (no port socket: the table and the backend
alone), judged by the emulated mount's own state.

Queries are answered from the Telescope's snapshot and one cached read of the stored settings, not by
a serial exchange each; each program keeps its own target; guarded commands get their row's refusal
until the owner allows them, then reach the mount; a refusal of the Telescope becomes the mount's code.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest

from alpaca_zwo import sky
from alpaca_zwo.bridges.zwo_backend import Session, SharedZone, TelescopeBackend
from alpaca_zwo.clients import ClientKey, ClientRegistry
from alpaca_zwo.config.settings import ZwoPortSettings
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.motion.interlock import Interlock
from alpaca_zwo.mount.operations import Mount
from alpaca_zwo.telescope.device import Telescope
from alpaca_zwo.zwo import dispatch
from alpaca_zwo.zwo.dispatch import Refusal
from alpaca_zwo.zwo.link import Link
from alpaca_zwo.zwo.wire_values import format_dms, format_hms, format_utc_offset, parse_hms
from tests.conftest import make_settings
from tests.support import wait_until
from tests.support.sites import NORTH, SITE_IDS, SITES, SYDNEY, Site

SPEED = 10.0  # emulated seconds per real second


@dataclass
class Rig:
    model: MountModel
    telescope: Telescope
    store: SettingsStore
    heard: list[str]  # every request body the emulated mount received

    def backend(self, port: int = 5000, zone: SharedZone | None = None) -> TelescopeBackend:
        """One program's backend, as the port builds one per connection."""
        return TelescopeBackend(self.telescope, Session(ClientKey(f"127.0.0.1:{port}", 1)), zone or SharedZone())

    def allow(self, *codes: str) -> None:
        self.store.update(lambda s: dataclasses.replace(
            s, zwo_port=dataclasses.replace(s.zwo_port, allow_dangerous=codes)))


@pytest.fixture
def rig(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Rig]:
    """The northern site, or the one a test passes (``parametrize("rig", SITES, indirect=True)``)."""
    site: Site = getattr(request, "param", NORTH)
    model = MountModel(ScaledClock(SPEED))
    heard: list[str] = []
    with EmulatorServer(model, host="127.0.0.1", port=0, baud=0) as emulator:
        answer = emulator.responder.handle

        def hearing(body: str) -> str | None:
            heard.append(body)
            return answer(body)

        emulator.responder.handle = hearing  # type: ignore[method-assign]
        store = SettingsStore(make_settings(zwo_port=ZwoPortSettings(enabled=True), site=site.settings()),
                              tmp_path / "config.toml")
        link = Link(f"socket://127.0.0.1:{emulator.port}", timeout=1.0)
        mount = Mount(link, lambda: (store.settings.site.latitude, store.settings.site.longitude),
                      clock=model.clock.now, monotonic=model.clock.seconds, clock_rate=SPEED)
        telescope = Telescope(mount, store, 0, registry=ClientRegistry(), interlock=Interlock())
        telescope.connection.set_connected(True)  # as the port does for its programs
        wait_until(lambda: mount.state.status is not None and mount.state.ra is not None, 30, "the first poll")
        try:
            yield Rig(model, telescope, store, heard)
        finally:
            telescope.shutdown()
            link.close()


def asked(rig: Rig, code: str, since: int = 0) -> int:
    """How many requests starting with ``code`` the mount received (after the first ``since``)."""
    return sum(1 for body in rig.heard[since:] if body.startswith(code))


def test_queries_are_answered_from_the_snapshot_and_one_cached_settings_read(rig: Rig) -> None:
    backend = rig.backend()
    t = rig.telescope
    since = len(rig.heard)  # the connect asked its own (:GVP#, the stored settings …)
    assert dispatch.answer(backend, "GVP") == f"{rig.model.firmware.model}#"
    assert dispatch.answer(backend, "GR") == format_hms(t.right_ascension()) + "#"
    assert dispatch.answer(backend, "GD") == format_dms(t.declination()) + "#"
    for _ in range(5):
        assert dispatch.answer(backend, "GLH") == f"{rig.model.flash.persist.upper_limit}#"
        assert dispatch.answer(backend, "GBu") == f"{rig.model.flash.persist.buzzer}#"
    assert (asked(rig, "GR", since), asked(rig, "GD", since), asked(rig, "GVP", since)) == (0, 0, 0)
    assert asked(rig, "GLH", since) <= 1, "the stored settings come from the one shared cache"


def test_each_program_keeps_its_own_target(rig: Rig) -> None:
    first, second = rig.backend(5000), rig.backend(5001)
    assert dispatch.answer(first, "Sr01:00:00") == "1"
    assert dispatch.answer(first, "Sd+10*00:00") == "1"
    assert dispatch.answer(second, "Sr02:00:00") == "1"
    assert dispatch.answer(second, "Sd+20*00:00") == "1"
    assert dispatch.answer(first, "GMeq") == "01:00:00&+10*00:00#"
    assert dispatch.answer(second, "GMeq") == "02:00:00&+20*00:00#"
    assert dispatch.answer(first, "Sd+95*00:00") == "e2#"  # out of range: refused, the target kept
    assert dispatch.answer(first, "Gd") == "+10*00:00#"
    assert asked(rig, "Sr") == asked(rig, "Sd") == 0, "a program's target stays on the server until its GOTO"


def test_a_guarded_command_gets_its_rows_refusal_until_the_owner_allows_it(rig: Rig) -> None:
    backend = rig.backend()
    for body, reply in (("SLH80", "0"), ("SS12:00:00", "e2#"), ("SBu0", None), ("NSC", "0")):
        with pytest.raises(Refusal) as refused:
            dispatch.answer(backend, body)
        assert refused.value.reply == reply, body
    assert rig.model.flash.persist.upper_limit == 90
    assert asked(rig, "SLH") == asked(rig, "SBu") == 0
    rig.allow("SLH")
    assert dispatch.answer(backend, "SLH80") == "1"  # through the stored settings' owner, to the mount
    assert rig.model.flash.persist.upper_limit == 80
    assert dispatch.answer(backend, "GLH") == "80#", "the setter marked the cached settings stale"
    with pytest.raises(Refusal):
        dispatch.answer(backend, "SBu0")  # still refused: not listed


def test_allowed_stored_settings_go_through_their_one_owner(rig: Rig) -> None:
    """Allowed, the port's setters of the mount's stored settings take ``StoredSettings.apply``'s path, as the
    Actions and the page do: a value its one rule refuses is answered as the mount answers it (``0``) and never
    reaches the mount; an accepted one is written, and every reader sees it."""
    backend = rig.backend()
    rig.allow("SLE", "SLD", "SLH", "SLL", "SRl", "SBu", "STa")
    since = len(rig.heard)
    for body in ("SLH55", "SLH91", "SLL31", "SRl999", "SRl12", "STa01+16"):
        assert dispatch.answer(backend, body) == "0", body
    assert dispatch.answer(backend, "SBu3") is None  # malformed (one digit 0-2): the row's silence
    assert rig.heard[since:] == [], "the owner's rule refused them before the mount was asked"
    assert dispatch.answer(backend, "SLH75") == "1"
    assert dispatch.answer(backend, "SLL20") == "1"
    assert dispatch.answer(backend, "SLE") == "1"
    assert dispatch.answer(backend, "SRl720") == "1"
    assert dispatch.answer(backend, "SBu2") is None  # :SBu# answers nothing
    assert dispatch.answer(backend, "STa01+05") == "1"
    flash = rig.model.flash
    assert (flash.limits_enabled(), flash.altitude_limits(), flash.max_speed(), flash.buzzer()) == (True, (20, 75),
                                                                                                     720, 2)
    writes = [body for body in rig.heard[since:] if body[:3] in ("SLH", "SLL", "SLE", "SRl", "SBu", "STa")]
    assert writes == ["SLH75", "SLL20", "SLE", "SRl720", "SBu2", "STa01+05"]
    stored = rig.telescope.stored_settings
    assert stored.meridian.limit_degrees == 5 and stored.meridian.track_after, "in force for DestinationSideOfPier"
    assert rig.store.settings.limits.meridian_limit_deg == 5, "the meridian mirrored in the configuration"
    current = stored.current()
    assert (current.limits_enabled, current.upper_limit, current.lower_limit, current.heavy_duty,
            current.buzzer) == (True, 75, 20, True, 2)
    for body, reply in (("GLC", "1#"), ("GLH", "75#"), ("GLL", "20#"), ("GRl", "720#"), ("GBu", "2#")):
        assert dispatch.answer(backend, body) == reply, body
    assert dispatch.answer(backend, "SLD") == "1"
    assert dispatch.answer(backend, "SRl1440") == "1"
    assert not flash.limits_enabled() and flash.max_speed() == 1440


def test_tracking_state_is_the_tables_reply_of_the_servers_state(rig: Rig) -> None:
    backend = rig.backend()
    assert dispatch.answer(backend, "Te") == "1"
    wait_until(lambda: rig.model.tracking_state()[0] and dispatch.answer(backend, "GAT") == "1#", 10, "on")
    assert dispatch.answer(backend, "Td") == "1"
    wait_until(lambda: not rig.model.tracking_state()[0] and dispatch.answer(backend, "GAT") == "0#", 10, "off")


def test_a_goto_the_telescope_refuses_answers_the_mounts_error_code(rig: Rig) -> None:
    """A target under the horizon: the Telescope refuses (InvalidValue), the port answers the mount's
    ``e5#`` through the GOTO row, and no GOTO reaches the mount."""
    backend = rig.backend()
    latitude = rig.telescope.capabilities.site_latitude()
    below = -80.0 if latitude > 0 else 80.0
    assert dispatch.answer(backend, "Sr12:00:00") == "1"
    assert dispatch.answer(backend, f"Sd{format_dms(below)}") == "1"
    altitude, _ = sky.equatorial_to_horizontal(sky.hour_angle(rig.telescope.clock.sidereal_time(), 12.0), below,
                                               latitude)
    assert altitude < 0
    with pytest.raises(Refusal) as refused:
        dispatch.answer(backend, "MS")
    assert refused.value.reply == "e5#"
    assert asked(rig, "MS") == 0


def _goto_reply(rig: Rig, backend: TelescopeBackend, altitude: float) -> str | None:
    """The port's reply to a GOTO to the meridian at ``altitude``: on the side away from the elevated pole,
    or under the horizon, below that pole (on the equator the meridian has no other point under it)."""
    latitude = rig.telescope.capabilities.site_latitude()
    ra = rig.telescope.clock.sidereal_time()
    if altitude >= 0.0:
        dec = latitude - math.copysign(90.0 - altitude, latitude)
    else:  # lower culmination: altitude = |latitude| + |dec| - 90
        ra = (ra + 12.0) % 24.0
        dec = math.copysign(90.0 + altitude - abs(latitude), latitude)
    assert dispatch.answer(backend, f"Sr{format_hms(ra)}") == "1"
    assert dispatch.answer(backend, f"Sd{format_dms(dec)}") == "1"
    try:
        return dispatch.answer(backend, "MS")
    except Refusal as refused:
        return refused.reply


@pytest.mark.parametrize("rig", SITES, ids=SITE_IDS, indirect=True)
def test_the_goto_refusal_code_is_the_one_limit_checks_verdict(rig: Rig) -> None:
    """``e5#`` for a horizon (the mount's at 0°, the configured profile), ``e6#`` for an altitude limit (the
    server's minimum, the mount's stored lower and upper ones): the code is read off the verdict
    ``Telescope.goto_limit`` gives, the same the page shows, and no refused GOTO reaches the mount. North,
    at Sydney and on the equator: the targets are on the meridian on the side away from the elevated pole."""
    backend = rig.backend()
    assert rig.model.clock_site.latitude() == pytest.approx(rig.telescope.settings.site.latitude, abs=0.02)  # pushed
    stored = rig.telescope.stored_settings
    stored.apply({"lower_limit": 25, "upper_limit": 70, "limits_enabled": True})
    stored.read()  # what the server knows of the mount's limits, as the poller's next read would
    assert _goto_reply(rig, backend, -20.0) == "e5#"  # under the mount's horizon
    assert _goto_reply(rig, backend, 15.0) == "e6#"  # under the mount's lower limit
    assert _goto_reply(rig, backend, 80.0) == "e6#"  # over its upper limit
    stored.apply({"limits_enabled": False})
    stored.read()
    profile = ((0.0, 30.0), (359.0, 30.0))
    rig.store.update(lambda s: dataclasses.replace(s, limits=dataclasses.replace(s.limits, horizon=profile)))
    assert _goto_reply(rig, backend, 20.0) == "e5#"  # under the configured horizon profile
    rig.store.update(lambda s: dataclasses.replace(s, limits=dataclasses.replace(s.limits, horizon=(),
                                                                                  min_altitude_deg=40.0)))
    assert _goto_reply(rig, backend, 35.0) == "e6#"  # under the server's minimum altitude
    assert asked(rig, "MS") == 0


@pytest.mark.parametrize("rig", [SYDNEY], indirect=True, ids=["sydney"])
def test_the_ports_zone_starts_as_the_mounts_the_sites(rig: Rig) -> None:
    """Until a program sets a zone, :GG#/:GL# are the mount's own, set in the site's zone (issue 43 point 3),
    not the host's: ASIAIR or INDI on the port shows Sydney's time on a Pi left on UTC."""
    backend = rig.backend()
    site_hours = (rig.model.clock.now().astimezone(ZoneInfo("Australia/Sydney")).utcoffset() or timedelta(0))
    assert rig.model.clock_site.utc_offset() == site_hours.total_seconds() / 3600.0
    assert dispatch.answer(backend, "GG") == format_utc_offset(rig.model.clock_site.utc_offset()) + "#"
    port_hours = parse_hms(dispatch.answer(backend, "GL")[:-1])
    local = rig.model.clock_site.local_datetime()
    mount_hours = local.hour + local.minute / 60.0 + local.second / 3600.0
    assert abs(sky.wrap_hours_12(port_hours - mount_hours)) * 3600.0 < 5 * SPEED  # emulated seconds


def test_the_zone_is_the_ports_and_a_malformed_one_changes_nothing(rig: Rig) -> None:
    """:SG# changes only the zone the port's programs see, one for the whole port; the mount keeps the
    server's. ``:SG5#`` (no sign) answers the refusal and, as on the mount, changes nothing (before
    issue 34 the port applied it all the same: a refusal that acted)."""
    zone = SharedZone()
    first, second = rig.backend(5000, zone), rig.backend(5001, zone)
    mount_zone = rig.model.clock_site.utc_offset()
    since = len(rig.heard)  # the connect pushed the server's zone
    assert dispatch.answer(first, "SG-03") == "1"
    assert dispatch.answer(second, "GG") == "-03:00#"
    assert dispatch.answer(first, "SG5") == "0"
    assert dispatch.answer(second, "GG") == "-03:00#"
    assert math.isclose(rig.model.clock_site.utc_offset(), mount_zone)
    assert asked(rig, "SG", since) == 0
