"""ZWO features beyond ITelescopeV4, served through Alpaca's ``Action()`` and ``SupportedActions``.

The mount stores settings no ASCOM member reaches (buzzer, heavy-duty mode, meridian behaviour,
altitude limits, EQ/alt-az mode) and the server has its own horizon limits; each is one
:class:`ZwoAction` in :data:`ACTIONS`, a table rather than an if-chain, so the guide
(docs/guide/actions.md), SupportedActions and the dispatcher cannot drift apart.

Conventions, the same for every action:

- Names are ``zwo:Name`` (the ASCOM ``vendor:Action`` style) and match case-insensitively.
- ``Parameters`` is a JSON object. Empty (``""``/``"{}"``) reads; keys write and the reply is the
  state read back afterwards, so a client sees what the mount really took.
- The reply is always a JSON object (a string, as Action returns strings).
- Every parameter is checked before anything is sent, so a bad one (InvalidValue 0x401) leaves the
  mount and the configuration untouched. Unknown names are ActionNotImplemented (0x40C); a
  disconnected device is NotConnected (0x407); link or mount failures are the Telescope's DriverErrors.
"""

from __future__ import annotations

import json
import logging
import math
import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from .._exceptions import (
    ActionNotImplemented,
    ConfigError,
    InvalidOperation,
    InvalidValue,
    MemberNotImplemented,
    NotConnected,
    mount_errors,
)
from ..config.settings import Settings, settings_from_dict, settings_to_dict
from ..motion.kinds import MotionKind
from ..zwo.wire_values import MeridianSettings, MountMode, MountStatus, parse_status
from .stored_settings import CHECKS

if TYPE_CHECKING:
    from ..config.store import SettingsStore
    from ..motion import MotionSupervisor
    from ..mount.operations import Mount
    from ..mount.state import MountSettings
    from .connection import Connection
    from .satellites import Satellites
    from .stored_settings import StoredSettings


class ActionDevice(Protocol):
    """What an action uses of its device (``device.Telescope`` is one). Declared here so that this
    module sits below the Telescope that dispatches to it, and the two import no circle."""

    mount: Mount
    store: SettingsStore
    motion: MotionSupervisor
    connection: Connection  # who holds the device connected
    stored_settings: StoredSettings  # the settings stored in the mount: their one check and write path
    satellites: Satellites  # the kept TLE sets and the follow of a pass (issue 41)

    @property
    def settings(self) -> Settings: ...


log = logging.getLogger(__name__)

BUZZER_LEVELS = ("off", "low", "high")  # :SBu0# .. :SBu2#
MODE_NAMES = {MountMode.EQUATORIAL: "equatorial", MountMode.ALTAZ: "altaz", MountMode.UNKNOWN: "unknown"}
RESTART_MESSAGE = ("The mount must be restarted (switched off and on) for the new mode to take effect; "
                   "until then it keeps working in {current} mode.")

Reply = dict[str, Any]


# ================================================================================================
# Parameter checks: each returns the value to use or raises ValueError with the reason
# ================================================================================================


def _is_number(value: object) -> bool:
    if isinstance(value, int) and not isinstance(value, bool):
        return abs(value) < 2**63  # a 400-digit integer cannot become a float (OverflowError)
    return isinstance(value, float) and math.isfinite(value)


def _number(low: float, high: float) -> Callable[[object], float]:
    def check(value: object) -> float:
        if not _is_number(value) or not low <= value <= high:  # type: ignore[operator]
            raise ValueError(f"must be a number from {low:g} to {high:g}, got {json.dumps(value)}")
        return float(value)  # type: ignore[arg-type]

    return check


def _choice(*names: str) -> Callable[[object], str]:
    def check(value: object) -> str:
        if not isinstance(value, str) or value.lower() not in names:
            raise ValueError(f"must be one of {', '.join(json.dumps(n) for n in names)}, got {json.dumps(value)}")
        return value.lower()

    return check


def _points(value: object) -> list[list[float]]:
    """The shape only; ranges and duplicates are the configuration's own rules (checked on save)."""
    if not isinstance(value, list) or not all(
            isinstance(p, list) and len(p) == 2 and all(_is_number(x) for x in p) for p in value):
        raise ValueError("must be an array of [azimuth, altitude] number pairs in degrees, "
                         "e.g. [[0, 10], [180, 25]]")
    return [[float(az), float(alt)] for az, alt in value]


def _boolean(value: object) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"must be true or false, got {json.dumps(value)}")
    return value


def _true(value: object) -> bool:
    if value is not True:
        raise ValueError(f"must be true (it clears every point), got {json.dumps(value)}")
    return True


@dataclass(frozen=True)
class Field:
    """A writable key of an action's parameter object."""

    check: Callable[[object], object]
    doc: str


# ================================================================================================
# Shared helpers
# ================================================================================================


def _settings(telescope: ActionDevice) -> MountSettings:
    """The settings stored in the mount (a few short queries); a value it did not report is None."""
    return telescope.mount.read_settings()


def _require_meridian_firmware(telescope: ActionDevice) -> None:
    info = telescope.mount.state.info
    if info is not None and not info.has_meridian_settings:
        raise MemberNotImplemented(f"this {info.model} has firmware {info.firmware}; meridian settings "
                                   "(:GTa#/:STa) need firmware 1.2.4 or later")


def _refuse_in_altaz(telescope: ActionDevice, action: str) -> None:
    """Meridian settings belong to a German mount: in alt-az mode (``Z`` in ``:GU#``) there is no meridian
    to stop at or flip over, so the action is refused before anything is sent."""
    status = telescope.mount.state.status
    if status is not None and status.mode is MountMode.ALTAZ:
        raise InvalidOperation(f"{action} does not apply in alt-az mode: an alt-az mount has no meridian limit or "
                               "flip (switch to equatorial mode with zwo:MountMode and restart the mount to use it)")


def _save(telescope: ActionDevice, action: str, section: str, values: Mapping[str, object]) -> Settings:
    """Persist configuration values through the settings store, as the setup page does.

    The store validates before it writes, so a refused value (InvalidValue) leaves both file and
    memory as they were; so does a failed write (SettingsNotSaved, a DriverError: not the client's value).
    """

    def change(current: Settings) -> Settings:
        data = settings_to_dict(current)
        data[section] = {**data[section], **values}
        return settings_from_dict(data, action)  # errors read "zwo:Horizon: limits.horizon: ..."

    try:
        return telescope.store.update(change)
    except ConfigError as exc:
        raise InvalidValue(str(exc)) from None


# ================================================================================================
# The actions: read (and write) handlers
# ================================================================================================


def _read_buzzer(telescope: ActionDevice) -> Reply:
    level = _settings(telescope).buzzer
    return {"volume": level, "name": BUZZER_LEVELS[level] if level in (0, 1, 2) else None}


def _write_buzzer(telescope: ActionDevice, changes: Reply) -> None:
    telescope.stored_settings.apply({"buzzer": changes["volume"]})


def _read_heavy_duty(telescope: ActionDevice) -> Reply:
    on = _settings(telescope).heavy_duty
    return {"enabled": on, "max_speed": None if on is None else (720 if on else 1440)}


def _write_heavy_duty(telescope: ActionDevice, changes: Reply) -> None:
    telescope.stored_settings.apply({"heavy_duty": changes["enabled"]})


def _read_meridian(telescope: ActionDevice) -> Reply:
    _refuse_in_altaz(telescope, "zwo:MeridianSettings")
    _require_meridian_firmware(telescope)
    meridian = _settings(telescope).meridian
    limits = telescope.settings.limits
    mount = None if meridian is None else {"track_past": meridian.track_after,
                                           "limit_degrees": meridian.limit_degrees, "flip": meridian.flip}
    return {**(mount or {"track_past": None, "limit_degrees": None, "flip": None}),
            "configured": {"track_past": limits.meridian_track_past,
                           "limit_degrees": round(limits.meridian_limit_deg)}}


def _write_meridian(telescope: ActionDevice, changes: Reply) -> None:
    _refuse_in_altaz(telescope, "zwo:MeridianSettings")
    _require_meridian_firmware(telescope)
    current = _settings(telescope).meridian or MeridianSettings()
    wanted = MeridianSettings(flip=current.flip,  # "temporarily not supported" by ZWO: kept as it is
                              track_after=changes.get("track_past", current.track_after),
                              limit_degrees=changes.get("limit_degrees", current.limit_degrees))
    # Mirrored in the configuration (saved first) and remembered for DestinationSideOfPier by the owner.
    telescope.stored_settings.apply({"meridian": wanted})


def _read_altitude_limits(telescope: ActionDevice) -> Reply:
    settings = _settings(telescope)
    return {"enabled": settings.limits_enabled, "upper": settings.upper_limit, "lower": settings.lower_limit}


#: zwo:AltitudeLimits' keys and the stored settings they are.
_ALTITUDE_KEYS = {"upper": "upper_limit", "lower": "lower_limit", "enabled": "limits_enabled"}


def _write_altitude_limits(telescope: ActionDevice, changes: Reply) -> None:
    telescope.stored_settings.apply({_ALTITUDE_KEYS[key]: value for key, value in changes.items()})


#: Mode asked for with :AA#/:AP# and not yet in effect, per telescope (the mount has no query for it).
_requested_modes: weakref.WeakKeyDictionary[ActionDevice, MountMode] = weakref.WeakKeyDictionary()


def _fresh_status(telescope: ActionDevice) -> tuple[str, MountStatus]:
    """``:GU#`` read now, raw and decoded. Also a round trip: every command sent before it (even a
    no-reply one such as ``:AA#``) has reached the mount by the time this returns."""
    raw = telescope.mount.raw(":GU#")
    return raw, parse_status(raw[:-1] if raw.endswith("#") else raw)


def _read_mode(telescope: ActionDevice, status: MountStatus | None = None) -> Reply:
    current = (status or _fresh_status(telescope)[1]).mode
    requested = _requested_modes.get(telescope, current)
    if requested is current:
        _requested_modes.pop(telescope, None)  # in effect now (the mount was restarted) or never changed
    reply: Reply = {"mode": MODE_NAMES[current], "requested": MODE_NAMES[requested],
                    "restart_required": requested is not current}
    if requested is not current:
        reply["message"] = RESTART_MESSAGE.format(current=MODE_NAMES[current])
    return reply


def _write_mode(telescope: ActionDevice, changes: Reply) -> None:
    request_mode(telescope, changes["mode"])


def request_mode(telescope: ActionDevice, name: str) -> None:
    """Send ``:AP#``/``:AA#`` for ``name`` ("equatorial" or "altaz") and remember it as requested: the mount
    applies it only after a restart (field notes §2.8), and then ``:GU#`` shows the new letter."""
    wanted = MountMode.EQUATORIAL if name == "equatorial" else MountMode.ALTAZ
    telescope.mount.set_mode(wanted is MountMode.EQUATORIAL)
    _requested_modes[telescope] = wanted
    log.warning("mount mode %s requested: the mount must be restarted for it to take effect", name)


def mode_report(telescope: ActionDevice, status: MountStatus | None = None) -> Reply:
    """The zwo:MountMode reply (current mode, requested mode, restart_required and its message); from
    ``status`` when given (the setup page passes the poller's, so its GET costs no exchange), else ``:GU#`` now."""
    return _read_mode(telescope, status)


def _read_info(telescope: ActionDevice) -> Reply:
    mount = telescope.mount
    info = mount.state.info
    raw, status = _fresh_status(telescope)  # exactly as the mount prints it
    link = mount.link.status
    return {
        "model": info.model if info else None,
        "firmware": info.firmware if info else None,
        "link": link.url,
        "link_state": link.state.value,
        "mode": MODE_NAMES[status.mode],
        "at_home": status.at_home,
        "status": {
            "raw": raw, "tracking": status.tracking, "slewing": status.slewing,
            "low_voltage": status.low_voltage, "at_home": status.at_home, "homing": status.homing,
            "mode": MODE_NAMES[status.mode], "ra_stall": status.ra_stall, "dec_stall": status.dec_stall,
            "st4_guiding_ra": status.st4_ra, "st4_guiding_dec": status.st4_dec, "parked": status.parked,
            "other_flags": status.other_flags, "digits": status.digits,
        },
    }


def _read_horizon(telescope: ActionDevice) -> Reply:
    limits = telescope.settings.limits
    return {"min_altitude_deg": limits.min_altitude_deg, "horizon": [list(p) for p in limits.horizon]}


def _write_horizon(telescope: ActionDevice, changes: Reply) -> None:
    _save(telescope, "zwo:Horizon", "limits", changes)


def _read_safety(telescope: ActionDevice) -> Reply:
    """The observatory interlock's verdict, as every motion start sees it (motion/interlock.py)."""
    verdict = telescope.motion.interlock.verdict
    return {"safe": verdict.safe, "source": verdict.source,
            "since": verdict.since.isoformat() if verdict.since else None,
            "state": verdict.state.value, "reason": verdict.reason}


def _read_pointing_model(telescope: ActionDevice) -> Reply:
    """The pointing model (docs/pointing-model.md): its points with residuals, terms ± σ, RMS, switch."""
    return telescope.mount.pointing.report()


def _write_pointing_model(telescope: ActionDevice, changes: Reply) -> None:
    if changes.get("clear"):
        telescope.mount.pointing.clear()
        log.info("pointing model cleared (zwo:PointingModel)")
    if "enabled" in changes:
        telescope.mount.pointing.set_enabled(changes["enabled"])
    telescope.mount.refresh()  # the position reads through the changed model at the next poll


def _tle_text(value: object) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > 600:
        raise ValueError('must be a satellite\'s TLE: "<name>\\n<line 1>\\n<line 2>" (at most 600 characters)')
    return value


def _stop_flag(value: object) -> bool:
    if value is not True:
        raise ValueError(f"must be true, got {json.dumps(value)}")
    return True


def _read_satellite(telescope: ActionDevice) -> Reply:
    """The follow running or last run (what it follows, its phase, its pointing error), the kept sets
    and the warnings about old ones."""
    satellites = telescope.satellites
    progress = satellites.progress()
    running = telescope.motion.running()
    reply: Reply = {"following": running is not None and running.kind is MotionKind.FOLLOW,
                    "satellites": [tle.name for tle in satellites.sets()], "warnings": satellites.warnings()}
    if progress is not None:
        reply.update({"name": progress.name, "phase": progress.phase, "ended": progress.ended,
                      "enters": progress.enters.isoformat(), "leaves": progress.leaves.isoformat(),
                      "error_arcmin": progress.error_arcmin, "rms_arcmin": progress.rms_arcmin,
                      "worst_arcmin": progress.worst_arcmin,
                      "acquired": progress.acquired.isoformat() if progress.acquired else None,
                      "lead_s": progress.lead_s,
                      "flip_at": progress.flip_at.isoformat() if progress.flip_at else None,
                      "resumes": progress.resumes.isoformat() if progress.resumes else None,
                      "reacquired": progress.reacquired.isoformat() if progress.reacquired else None})
    return reply


def _write_satellite(telescope: ActionDevice, changes: Reply) -> None:
    if "stop" in changes and "tle" in changes:
        raise InvalidValue("zwo:TrackSatellite: give either tle (start) or stop, not both")
    if "stop" in changes:
        telescope.satellites.stop()
        return
    if telescope.motion.parked:
        raise InvalidOperation("zwo:TrackSatellite: the mount is parked; unpark it first")
    (tle, *_) = telescope.satellites.add(changes["tle"])
    telescope.satellites.follow(tle)


# ================================================================================================
# The table
# ================================================================================================


@dataclass(frozen=True)
class ZwoAction:
    """One action: how to read its state and, if writable, which keys it takes and how to apply them."""

    name: str
    summary: str
    read: Callable[[ActionDevice], Reply]
    fields: Mapping[str, Field] = field(default_factory=dict)
    write: Callable[[ActionDevice, Reply], None] | None = None
    example: str = "{}"  # a write example for the documentation


ACTIONS: tuple[ZwoAction, ...] = (
    ZwoAction("zwo:BuzzerVolume", "The mount's buzzer volume (:GBu#/:SBu).", _read_buzzer,
              {"volume": Field(CHECKS["buzzer"], "0 off, 1 low, 2 high")}, _write_buzzer, '{"volume": 1}'),
    ZwoAction("zwo:HeavyDutyMode", "Heavy-duty mode: top speed 720x instead of 1440x (:GRl#/:SRl).",
              _read_heavy_duty, {"enabled": Field(CHECKS["heavy_duty"], "true or false")}, _write_heavy_duty,
              '{"enabled": true}'),
    ZwoAction("zwo:MeridianSettings", "Meridian behaviour stored in the mount (:GTa#/:STa, firmware >= 1.2.4); "
              "writes are also saved in the configuration, which is pushed to the mount on every connect.",
              _read_meridian,
              {"track_past": Field(CHECKS["meridian.track_after"], "keep tracking past the meridian up to the limit"),
               "limit_degrees": Field(CHECKS["meridian.limit_degrees"], "-15..15; negative stops before the meridian")},
              _write_meridian, '{"track_past": true, "limit_degrees": 10}'),
    ZwoAction("zwo:AltitudeLimits", "The mount's own altitude limits (:GLC#/:GLH#/:GLL#, :SLE#/:SLD#/:SLH/:SLL).",
              _read_altitude_limits,
              {"enabled": Field(CHECKS["limits_enabled"], "limits on or off"),
               "upper": Field(CHECKS["upper_limit"], "60..90 degrees"),
               "lower": Field(CHECKS["lower_limit"], "0..30 degrees")},
              _write_altitude_limits, '{"enabled": true, "upper": 85, "lower": 10}'),
    ZwoAction("zwo:MountMode", "Equatorial or alt-az mode (:AP#/:AA#); a switch takes effect only after the "
              "mount is restarted, which the reply says.", _read_mode,
              {"mode": Field(_choice("equatorial", "altaz"), '"equatorial" or "altaz"')}, _write_mode,
              '{"mode": "altaz"}'),
    ZwoAction("zwo:MountInfo", "Model, firmware, serial link, mode, home flag and the decoded :GU# flags "
              "(read-only).", _read_info),
    ZwoAction("zwo:Horizon", "The server's own pointing floor: minimum altitude and horizon profile "
              "(configuration, saved to the config file).", _read_horizon,
              {"min_altitude_deg": Field(_number(-10.0, 60.0), "-10..60 degrees"),
               "horizon": Field(_points, "[[azimuth, altitude], ...] in degrees, [] for none")},
              _write_horizon, '{"min_altitude_deg": 5, "horizon": [[0, 10], [90, 20], [180, 15]]}'),
    ZwoAction("zwo:PointingModel", "The pointing model built from syncs: points, residuals, terms ± σ and RMS; "
              "clears it or switches it on and off (docs/pointing-model.md).", _read_pointing_model,
              {"enabled": Field(_boolean, "true or false: apply the model"),
               "clear": Field(_true, "true: forget every point")},
              _write_pointing_model, '{"enabled": false}'),
    ZwoAction("zwo:Safety", "The observatory interlock: whether motion may start by the configured SafetyMonitor "
              "and roof, which device decided, since when, and why (read-only).", _read_safety),
    ZwoAction("zwo:TrackSatellite", "Follow a satellite's next pass from its TLE (kept beside the configuration): "
              "waits where the pass enters the allowed sky, then drives the axes' speeds until it leaves; "
              "stop ends it; empty Parameters read the progress, the pointing error and old-set warnings "
              "(docs/satellites.md).", _read_satellite,
              {"tle": Field(_tle_text, '"<name>\\n<line 1>\\n<line 2>": keep this set and follow its next pass'),
               "stop": Field(_stop_flag, "true: stop following")},
              _write_satellite, '{"tle": "ISS (ZARYA)\\n1 25544U ...\\n2 25544 ..."}'),
)

_BY_NAME: dict[str, ZwoAction] = {action.name.lower(): action for action in ACTIONS}


def supported_actions() -> list[str]:
    """The action names SupportedActions lists, exactly as documented."""
    return [action.name for action in ACTIONS]


def _changes(action: ZwoAction, parameters: str) -> Reply:
    """The checked keys to write; empty means read. Raises InvalidValue before anything is sent."""
    text = (parameters or "").strip()
    if not text:
        return {}
    try:
        given = json.loads(text)
    except ValueError as exc:
        raise InvalidValue(f"{action.name}: Parameters must be a JSON object such as {action.example}, "
                           f"or empty to read ({exc})") from None
    except RecursionError:  # json's decoder stops at ~1000 levels; no action takes more than two
        raise InvalidValue(f"{action.name}: Parameters are nested too deeply; it takes a JSON object such as "
                           f"{action.example}") from None
    if not isinstance(given, dict):
        raise InvalidValue(f"{action.name}: Parameters must be a JSON object such as {action.example}, "
                           f"not {json.dumps(given)[:60]}")
    if given and action.write is None:
        raise InvalidValue(f"{action.name} is read-only: call it with empty Parameters")
    unknown = sorted(set(given) - set(action.fields))
    if unknown:
        raise InvalidValue(f"{action.name}: unknown key(s) {', '.join(unknown)}; it takes "
                           f"{', '.join(action.fields)}")
    changes = {}
    for key, value in given.items():
        try:
            changes[key] = action.fields[key].check(value)
        except ValueError as exc:
            raise InvalidValue(f"{action.name}: {key} {exc}") from None
    return changes


def run_action(telescope: ActionDevice, name: str, parameters: str) -> str:
    """Run one action by name (case-insensitive): write the given keys, then return the state as JSON."""
    action = _BY_NAME.get(name.strip().lower())
    if action is None:
        raise ActionNotImplemented(f"action {name!r} is not supported; SupportedActions lists "
                                   f"{', '.join(supported_actions())}")
    # As every other member: connected while any client holds the device and the mount link runs.
    if not telescope.connection.clients() or not telescope.mount.running:
        raise NotConnected(f"{action.name} needs the telescope connected: set Connected=true or call Connect")
    changes = _changes(action, parameters)
    with mount_errors(action.name):
        if changes and action.write is not None:
            action.write(telescope, changes)
        reply = action.read(telescope)
    return json.dumps(reply, allow_nan=False)
