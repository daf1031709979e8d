"""The settings stored in the mount (meridian behaviour, altitude limits, heavy duty, buzzer): one owner.

Every door that changes one goes through :class:`StoredSettings`: the ``zwo:*`` Actions, the setup page
(through the facade) and the shared ZWO port. So each value is checked by one rule (:data:`CHECKS`),
and written by one path (:meth:`StoredSettings.apply`): the meridian setting is mirrored in the
configuration first (the configuration is pushed to the mount on every connect, so it must agree), then
every value is written to the mount in a fixed order; if the mount refuses one, the mirror is put back.
A save that fails (full disk) therefore changes nothing.

It also keeps the mount's meridian setting as last read or written (:attr:`StoredSettings.meridian`),
what DestinationSideOfPier, the GOTO side and a pier flip's restore use. That is not the settings cache
(``mount/settings_cache.py``, what the page shows, refreshed by the poller): a pier flip's temporary
limit may sit in the cache for a while, and must never become the setting a flip restores.
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from .. import sky
from .._exceptions import ConfigError, DriverError, InvalidValue, mount_errors
from ..config.settings import Settings, settings_from_dict, settings_to_dict
from ..config.store import SettingsStore
from ..mount.operations import Mount
from ..mount.state import MountSettings
from ..zwo.wire_values import MeridianSettings

log = logging.getLogger(__name__)

#: A value's check: returns the value to use or raises ValueError with the reason ("must be ...").
Check = Callable[[object], Any]


def whole(low: int, high: int) -> Check:
    """An integer from ``low`` to ``high`` (a JSON ``true`` is not one)."""

    def check(value: object) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ValueError(f"must be an integer from {low} to {high}, got {json.dumps(value)}")
        return value

    return check


def truth(value: object) -> bool:
    """true or false, nothing else (no 0/1, no strings)."""
    if not isinstance(value, bool):
        raise ValueError(f"must be true or false, got {json.dumps(value)}")
    return value


#: The one range check of each stored value, by its name in ``MountSettings`` (the meridian by its parts).
#: The mount's own ranges: ZWO v2.1 p.18 (:STa -15..+15), :SLH 60..90, :SLL 0..30, :SBu 0..2.
CHECKS: dict[str, Check] = {
    "meridian.track_after": truth,
    "meridian.limit_degrees": whole(-15, 15),
    "limits_enabled": truth,
    "upper_limit": whole(60, 90),
    "lower_limit": whole(0, 30),
    "heavy_duty": truth,
    "buzzer": whole(0, 2),
}


def check_meridian(value: object) -> MeridianSettings:
    if not isinstance(value, MeridianSettings):
        raise ValueError(f"must be a meridian setting, got {value!r}")
    CHECKS["meridian.track_after"](value.track_after)
    CHECKS["meridian.limit_degrees"](value.limit_degrees)
    truth(value.flip)
    return value


@dataclass(frozen=True)
class _Writer:
    check: Check
    write: Callable[[Mount, Any], None]


#: Every stored setting a door may change, in the order a change writes them.
_WRITERS: dict[str, _Writer] = {
    "meridian": _Writer(check_meridian, Mount.set_meridian),
    "upper_limit": _Writer(CHECKS["upper_limit"], Mount.set_upper_limit),
    "lower_limit": _Writer(CHECKS["lower_limit"], Mount.set_lower_limit),
    "limits_enabled": _Writer(CHECKS["limits_enabled"], Mount.set_limits_enabled),
    "heavy_duty": _Writer(CHECKS["heavy_duty"], Mount.set_heavy_duty),
    "buzzer": _Writer(CHECKS["buzzer"], Mount.set_buzzer),
}
#: The names :meth:`StoredSettings.apply` takes, in the order it writes them.
NAMES: tuple[str, ...] = tuple(_WRITERS)


class StoredSettings:
    """The mount's stored settings: checked, mirrored, written, restored; the meridian setting in force.

    One lock, ``_read_lock``: programs asking for the settings at once (:meth:`current`) share one
    read; held across that read, it takes no other lock. The settings store locks its save, the link
    serialises the writes, and :attr:`meridian` is one value replaced whole.
    """

    def __init__(self, *, mount: Mount, store: SettingsStore) -> None:
        self.mount = mount
        self.store = store
        #: The mount's meridian setting as last read or written: DestinationSideOfPier and pier flips use it.
        self.meridian = MeridianSettings()
        self._read_lock = threading.Lock()

    # -- what is stored ----------------------------------------------------------------------------

    def configured_meridian(self) -> MeridianSettings:
        """The meridian setting the configuration holds (pushed to the mount on every connect)."""
        limits = self.store.settings.limits
        return MeridianSettings(False, limits.meridian_track_past, round(limits.meridian_limit_deg))

    def flip_line_deg(self) -> float:
        """Where the mount flips a GOTO now, by its meridian setting in force (``sky.flip_line_deg``)."""
        return sky.flip_line_deg(float(self.meridian.limit_degrees), self.meridian.track_after)

    def cached(self) -> MountSettings | None:
        """As last read, without a serial exchange (``mount/settings_cache.py``); None if never read."""
        return self.mount.settings

    def read(self) -> MountSettings:
        """Read from the mount now (eight short queries); also refreshes the cache."""
        return self.mount.read_settings()

    def current(self) -> MountSettings:
        """From the Mount's one shared cache (the page and the Actions read it too), read from the mount
        only when never read, marked stale by a command since, or a minute old; that read refills the
        cache for everyone (the shared ZWO port answers its queries from here)."""
        with self._read_lock:
            cache = self.mount.settings_cache
            cached = cache.value
            if cached is None or cache.due():
                return self.mount.read_settings()
            return cached

    # -- changing them -----------------------------------------------------------------------------

    def apply(self, changes: Mapping[str, object]) -> None:
        """Write ``changes`` (names of :data:`NAMES` to values) to the mount: the one path for every door.

        Every value is checked first (InvalidValue, nothing sent). A meridian setting is then saved in the
        configuration (SettingsNotSaved: nothing sent), then the values are written in :data:`NAMES`
        order; if the mount refuses one or the link fails (the mount's and the link's own errors, which
        each door words itself), the configuration's meridian is put back and the values already written
        stay (the mount took them; the next read shows them).
        """
        unknown = sorted(set(changes) - set(_WRITERS))
        if unknown:
            raise InvalidValue(f"not a setting stored in the mount: {', '.join(unknown)}")
        checked: dict[str, Any] = {}
        for name in NAMES:
            if name in changes:
                try:
                    checked[name] = _WRITERS[name].check(changes[name])
                except ValueError as exc:
                    raise InvalidValue(f"{name} {exc}") from None
        meridian = checked.get("meridian")
        before = self.store.settings.limits
        if meridian is not None:
            self._mirror(meridian.track_after, meridian.limit_degrees)
        try:
            for name, value in checked.items():
                _WRITERS[name].write(self.mount, value)
                if name == "meridian":
                    self.meridian = value  # remembered for DestinationSideOfPier
        except Exception:
            if meridian is not None:
                self._mirror(before.meridian_track_past, before.meridian_limit_deg)
            raise

    def _mirror(self, track_past: bool, limit_deg: float) -> None:
        """Save the meridian setting in the configuration (validated by the store before it writes)."""

        def change(current: Settings) -> Settings:
            data = settings_to_dict(current)
            data["limits"] = {**data["limits"], "meridian_track_past": track_past, "meridian_limit_deg": limit_deg}
            return settings_from_dict(data, "the mount's meridian setting")

        try:
            self.store.update(change)
        except ConfigError as exc:
            raise InvalidValue(str(exc)) from None

    # -- at connect --------------------------------------------------------------------------------

    def push_configured(self) -> None:
        """The configuration is the single source of truth: a replaced or reset mount gets it back.
        Reads what the mount holds (remembered as in force), then writes the configured setting if it differs."""
        settings = self.read()
        wanted = self.configured_meridian()
        if settings.meridian is None:
            return
        self.meridian = settings.meridian
        if settings.meridian == wanted:
            return
        try:
            with mount_errors("setting the meridian behaviour"):
                self.mount.set_meridian(wanted)
            self.meridian = wanted
            log.info("mount meridian setting %s replaced by the configured %s", settings.meridian, wanted)
        except DriverError as exc:
            log.warning("could not apply the configured meridian setting: %s", exc.message)
