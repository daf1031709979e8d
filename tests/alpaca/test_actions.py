"""The ZWO Actions (alpaca_zwo/telescope/actions.py) through alpyca, on a real server with the built-in emulator.

Every read is compared with the emulator's own state and every write is checked there (and in the
config file for server settings). Bad parameters must be InvalidValue with nothing sent to the
mount: the link trace must show none of the action's commands, and the emulator must be unchanged.
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from alpaca.exceptions import (
    ActionNotImplementedException,
    InvalidValueException,
    NotConnectedException,
    NotImplementedException,
)
from alpaca.telescope import PierSide
from alpaca.telescope import Telescope as AlpycaTelescope

from alpaca_zwo.config.file import load_settings
from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope.actions import ACTIONS
from alpaca_zwo.zwo.wire_values import MeridianSettings, MountMode
from tests.conftest import ServerFactory, make_settings
from tests.support.wait import wait_until

ACTIONS_PAGE = Path(__file__).resolve().parents[2] / "docs" / "guide" / "actions.md"
#: Every command an action may send (reads and writes): none may reach the mount for a bad parameter.
ACTION_CODES = ("SBu", "GBu", "SRl", "GRl", "STa", "GTa", "SLE", "SLD", "GLC", "SLH", "GLH", "SLL", "GLL",
                "AA", "AP", "Ggr", "GH")


@dataclass
class Rig:
    server: AlpacaZwoServer
    scope: AlpycaTelescope
    model: MountModel

    def action(self, name: str, parameters: Any = None) -> dict[str, Any]:
        """Run an action; a dict is sent as its JSON text, None as no Parameters at all (alpyca's way)."""
        if parameters is None:
            reply = self.scope.Action(name)
        else:
            text = parameters if isinstance(parameters, str) else json.dumps(parameters)
            reply = self.scope.Action(name, text)
        value = json.loads(reply)
        assert isinstance(value, dict), reply
        return value

    def sent_since(self, start: int) -> list[str]:
        """Requests the server sent to the mount after trace entry ``start``."""
        return [entry.request for entry in self.server.telescopes[0].mount.link.trace()[start:]]

    def trace_length(self) -> int:
        return len(self.server.telescopes[0].mount.link.trace())


def _start(server_factory: ServerFactory, **emulator: Any) -> Rig:
    settings = make_settings(emulator=EmulatorSettings(speed=1.0, baud=0, **emulator))
    server = server_factory(settings)
    scope = AlpycaTelescope(f"127.0.0.1:{server.port}", 0)
    model = server.emulators[0].model
    assert model is not None
    return Rig(server, scope, model)


@pytest.fixture
def rig(server_factory: ServerFactory) -> Iterator[Rig]:
    rig = _start(server_factory)
    rig.scope.Connected = True
    yield rig
    rig.scope.Connected = False


@pytest.fixture(scope="module")
def shared_rig(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Rig]:
    """One connected server for the refusal tests, which change nothing (and check that they do not)."""
    store = SettingsStore(make_settings(emulator=EmulatorSettings(speed=1.0, baud=0)),
                          tmp_path_factory.mktemp("actions") / "config.toml")
    server = AlpacaZwoServer(store)
    server.start()
    try:
        model = server.emulators[0].model
        assert model is not None
        rig = Rig(server, AlpycaTelescope(f"127.0.0.1:{server.port}", 0), model)
        rig.scope.Connected = True
        yield rig
    finally:
        server.stop()


def wait_for(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.02)


# ================================================================================================
# The list
# ================================================================================================


def test_supported_actions_lists_exactly_the_implemented_ones(rig: Rig) -> None:
    names = rig.scope.SupportedActions
    assert names == [action.name for action in ACTIONS]
    assert all(re.fullmatch(r"zwo:[A-Z][A-Za-z]+", name) for name in names)
    for name in names:  # each one listed actually runs
        assert rig.action(name)


def test_the_guide_documents_every_action() -> None:
    """The guide's Actions page has a heading and an alpyca example for each action, and no others."""
    section = ACTIONS_PAGE.read_text(encoding="utf-8")
    documented = re.findall(r"^## `(zwo:\w+)`", section, flags=re.MULTILINE)
    assert documented == [action.name for action in ACTIONS]
    for name in documented:
        assert f'T.Action("{name}"' in section, f"no alpyca example for {name}"


def test_supported_actions_needs_no_connection(server_factory: ServerFactory) -> None:
    rig = _start(server_factory)
    assert rig.scope.SupportedActions == [action.name for action in ACTIONS]


# ================================================================================================
# Each action: read against the emulator, write and check the emulator
# ================================================================================================


def test_buzzer_volume(rig: Rig) -> None:
    rig.model.flash.set_buzzer(0)
    assert rig.action("zwo:BuzzerVolume") == {"volume": 0, "name": "off"}
    start = rig.trace_length()
    assert rig.action("zwo:BuzzerVolume", {"volume": 2}) == {"volume": 2, "name": "high"}
    sent = rig.sent_since(start)  # also shows the trace filter of the bad-parameter test sees real commands
    assert ":SBu2#" in sent and ":GBu#" in sent[sent.index(":SBu2#"):], sent  # written, then read back
    assert rig.model.flash.buzzer() == 2
    assert rig.action("zwo:BuzzerVolume", {"volume": 1})["name"] == "low" and rig.model.flash.buzzer() == 1


def test_heavy_duty_mode(rig: Rig) -> None:
    assert rig.action("zwo:HeavyDutyMode") == {"enabled": False, "max_speed": 1440}
    assert rig.action("zwo:HeavyDutyMode", {"enabled": True}) == {"enabled": True, "max_speed": 720}
    assert rig.model.flash.max_speed() == 720
    rig.model.flash.set_max_speed(1440)  # changed behind the server's back (e.g. by the ZWO app): read, not cached
    assert rig.action("zwo:HeavyDutyMode")["enabled"] is False


def test_meridian_settings_reach_the_mount_and_the_config_file(rig: Rig) -> None:
    reply = rig.action("zwo:MeridianSettings", {"track_past": True, "limit_degrees": 10})
    assert reply == {"track_past": True, "limit_degrees": 10, "flip": False,
                     "configured": {"track_past": True, "limit_degrees": 10}}
    assert rig.model.flash.meridian() == MeridianSettings(flip=False, track_after=True, limit_degrees=10)
    saved = load_settings(rig.server.store.path).limits
    assert (saved.meridian_track_past, saved.meridian_limit_deg) == (True, 10.0)
    # A partial write keeps the other value.
    reply = rig.action("zwo:MeridianSettings", {"limit_degrees": -5})
    assert (reply["track_past"], reply["limit_degrees"]) == (True, -5)
    assert rig.model.flash.meridian() == MeridianSettings(flip=False, track_after=True, limit_degrees=-5)


def test_meridian_settings_refused_on_old_firmware(server_factory: ServerFactory) -> None:
    """Field notes §5.6: no :GTa/:STa before firmware 1.2.4; the server sends neither."""
    rig = _start(server_factory, firmware="1.2.0")
    rig.scope.Connected = True
    start = rig.trace_length()
    for parameters in (None, {"limit_degrees": 5}):
        with pytest.raises(NotImplementedException, match=r"1\.2\.4"):
            rig.action("zwo:MeridianSettings", parameters)
    assert not [r for r in rig.sent_since(start) if r.startswith((":STa", ":GTa"))]
    assert rig.model.flash.meridian() == MeridianSettings()


def test_old_firmware_cannot_flip_and_its_gotos_never_touch_the_meridian_setting(
        server_factory: ServerFactory) -> None:
    """Before 1.2.4 there is no :STa, so the server cannot choose a pier side: CanSetPierSide is false,
    a SideOfPier write is NotImplemented, and a GOTO (which elsewhere may keep pierEast by a temporary
    limit) goes out as a plain GOTO and is accepted."""
    rig = _start(server_factory, firmware="1.2.0")
    rig.scope.Connected = True
    assert rig.scope.CanSetPierSide is False
    start = rig.trace_length()
    with pytest.raises(NotImplementedException, match=r"1\.2\.4"):
        rig.scope.SideOfPier = PierSide.pierWest
    rig.scope.Tracking = True
    for ha in (2.0, 0.02):  # onto pierEast, then just past the meridian: the kept-east case
        rig.scope.SlewToCoordinatesAsync((rig.scope.SiderealTime - ha) % 24.0, 30.0)
        wait_until(lambda: not rig.scope.Slewing, 120.0, "the GOTO to end")
    assert not [r for r in rig.sent_since(start) if r.startswith((":STa", ":GTa"))]


def test_altitude_limits(rig: Rig) -> None:
    assert rig.action("zwo:AltitudeLimits") == {"enabled": False, "upper": 90, "lower": 0}
    reply = rig.action("zwo:AltitudeLimits", {"enabled": True, "upper": 80, "lower": 15})
    assert reply == {"enabled": True, "upper": 80, "lower": 15}
    assert rig.model.flash.limits_enabled() is True and rig.model.flash.altitude_limits() == (15, 80)
    assert rig.action("zwo:AltitudeLimits", {"lower": 0}) == {"enabled": True, "upper": 80, "lower": 0}
    rig.model.flash.set_limits_enabled(False)
    assert rig.action("zwo:AltitudeLimits")["enabled"] is False


def test_mount_mode_switch_needs_a_restart(rig: Rig) -> None:
    """Field notes §2.8: :AA#/:AP# take effect only after the mount is restarted, and the reply says so."""
    assert rig.action("zwo:MountMode") == {"mode": "equatorial", "requested": "equatorial",
                                           "restart_required": False}
    reply = rig.action("zwo:MountMode", {"mode": "altaz"})
    assert reply["mode"] == "equatorial" and reply["requested"] == "altaz" and reply["restart_required"] is True
    assert "restarted" in reply["message"]
    assert rig.model.flash.mode() is MountMode.EQUATORIAL  # not yet
    assert rig.action("zwo:MountMode")["restart_required"] is True  # still pending on a later read

    rig.model.power_cycle()  # the user restarts the mount
    assert rig.model.flash.mode() is MountMode.ALTAZ
    wait_for(lambda: rig.action("zwo:MountMode")["mode"] == "altaz", 10, "the server to see alt-az mode")
    assert rig.action("zwo:MountMode") == {"mode": "altaz", "requested": "altaz", "restart_required": False}

    # Asking for the mode already in effect needs no restart.
    assert rig.action("zwo:MountMode", {"mode": "ALTAZ"})["restart_required"] is False
    assert rig.action("zwo:MountMode", {"mode": "equatorial"})["restart_required"] is True
    rig.model.power_cycle()
    wait_for(lambda: rig.action("zwo:MountMode")["mode"] == "equatorial", 10, "equatorial mode again")


def test_mount_info(rig: Rig) -> None:
    info = rig.action("zwo:MountInfo")
    firmware = rig.model.firmware
    assert (info["model"], info["firmware"]) == (firmware.model, firmware.version)
    assert info["link"] == rig.server.emulators[0].url and info["link_state"] == "connected"
    assert info["mode"] == "equatorial" and info["status"]["mode"] == "equatorial"
    status = info["status"]
    assert re.fullmatch(r"[A-Za-z]*\d+#", status["raw"]) and status["digits"] in status["raw"]
    assert status["tracking"] is rig.scope.Tracking is False and status["slewing"] is False
    assert info["at_home"] is False

    rig.scope.FindHome()
    wait_for(lambda: not rig.scope.Slewing, 60, "FindHome to finish")
    info = rig.action("zwo:MountInfo")
    assert info["at_home"] is True and info["status"]["at_home"] is True and "H" in info["status"]["raw"]
    rig.scope.Tracking = True
    assert rig.action("zwo:MountInfo")["status"]["tracking"] is True


def test_horizon_is_saved_and_used(rig: Rig) -> None:
    assert rig.action("zwo:Horizon") == {"min_altitude_deg": 0.0, "horizon": []}
    reply = rig.action("zwo:Horizon", {"min_altitude_deg": 60, "horizon": [[180, 20], [0, 10]]})
    assert reply == {"min_altitude_deg": 60.0, "horizon": [[0.0, 10.0], [180.0, 20.0]]}
    saved = load_settings(rig.server.store.path).limits
    assert saved.min_altitude_deg == 60.0 and saved.horizon == ((0.0, 10.0), (180.0, 20.0))
    # The server's slews obey it at once: the celestial equator on the meridian is at 38.5° here.
    rig.scope.Tracking = True
    with pytest.raises(InvalidValueException, match="below the horizon limit"):
        rig.scope.SlewToCoordinatesAsync(rig.scope.SiderealTime, 0.0)
    assert rig.action("zwo:Horizon", {"horizon": []}) == {"min_altitude_deg": 60.0, "horizon": []}


# ================================================================================================
# Refusals
# ================================================================================================

BAD_PARAMETERS = [
    ("zwo:BuzzerVolume", '{"volume": 3}'),
    ("zwo:BuzzerVolume", '{"volume": true}'),
    ("zwo:BuzzerVolume", '{"volume": "2"}'),
    ("zwo:BuzzerVolume", '{"loudness": 1}'),
    ("zwo:BuzzerVolume", "2"),
    ("zwo:BuzzerVolume", "[1]"),
    ("zwo:BuzzerVolume", "{volume: 1}"),
    ("zwo:HeavyDutyMode", '{"enabled": 1}'),
    ("zwo:MeridianSettings", '{"limit_degrees": 16}'),
    ("zwo:MeridianSettings", '{"track_past": true, "limit_degrees": 5.5}'),
    ("zwo:AltitudeLimits", '{"upper": 59}'),
    ("zwo:AltitudeLimits", '{"enabled": true, "lower": -1}'),  # one bad key: nothing at all is applied
    ("zwo:AltitudeLimits", '{"lower": 31}'),
    ("zwo:MountMode", '{"mode": "polar"}'),
    ("zwo:MountMode", '{}  {}'),
    ("zwo:MountInfo", '{"model": "AM7"}'),
    ("zwo:Horizon", '{"min_altitude_deg": 61}'),
    ("zwo:Horizon", '{"min_altitude_deg": NaN}'),
    ("zwo:Horizon", '{"horizon": [[0, 95]]}'),
    ("zwo:Horizon", '{"horizon": [[0, 10, 3]]}'),
    ("zwo:Horizon", '{"horizon": [[400, 10]]}'),
]


def _emulator_settings(model: MountModel) -> tuple[object, ...]:
    flash = model.flash
    return (flash.buzzer(), flash.max_speed(), flash.meridian(), flash.limits_enabled(), flash.altitude_limits(),
            flash.mode())


@pytest.mark.parametrize(("name", "parameters"), BAD_PARAMETERS)
def test_bad_parameters_are_invalid_value_and_nothing_is_sent(shared_rig: Rig, name: str, parameters: str) -> None:
    rig = shared_rig
    before = _emulator_settings(rig.model)
    limits = rig.server.settings.limits
    saved = rig.server.store.path.read_text(encoding="utf-8") if rig.server.store.path.exists() else ""
    start = rig.trace_length()
    with pytest.raises(InvalidValueException, match=name):
        rig.action(name, parameters)
    sent = [r for r in rig.sent_since(start) if r.lstrip(":").startswith(ACTION_CODES)]
    assert sent == [], f"sent to the mount for a bad parameter: {sent}"
    assert _emulator_settings(rig.model) == before
    assert rig.server.settings.limits == limits
    if saved:
        assert rig.server.store.path.read_text(encoding="utf-8") == saved


def test_unknown_names_are_action_not_implemented(shared_rig: Rig) -> None:
    rig = shared_rig
    for name in ("zwo:Nope", "BuzzerVolume", "zwo:BuzzerVolumes", "", "zwo:"):
        with pytest.raises(ActionNotImplementedException):
            rig.action(name, "{}")


def test_names_match_case_insensitively(shared_rig: Rig) -> None:
    rig = shared_rig
    rig.model.flash.set_buzzer(1)
    for name in ("zwo:buzzervolume", "ZWO:BUZZERVOLUME", "Zwo:BuzzerVolume"):
        assert rig.action(name)["volume"] == 1
    assert rig.action("ZWO:buzzerVOLUME", {"volume": 0})["volume"] == 0 and rig.model.flash.buzzer() == 0


@pytest.mark.parametrize("parameters", [None, "", "{}", "  ", " {} "])
def test_empty_parameters_read(shared_rig: Rig, parameters: str | None) -> None:
    rig = shared_rig
    rig.model.flash.set_buzzer(2)
    assert rig.action("zwo:BuzzerVolume", parameters) == {"volume": 2, "name": "high"}


def test_every_action_needs_a_connection(server_factory: ServerFactory) -> None:
    rig = _start(server_factory)
    for action in ACTIONS:
        with pytest.raises(NotConnectedException):
            rig.action(action.name)
    with pytest.raises(ActionNotImplementedException):  # an unknown name is still just unknown
        rig.action("zwo:Nope")
