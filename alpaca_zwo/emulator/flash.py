"""What the mount keeps in flash and exposes as settings: meridian, altitude limits, top speed, mode,
buzzer and Bluetooth identity (kept across power cycles and the ``reboot`` fault)."""

from __future__ import annotations

import threading
from collections.abc import Callable

from ..zwo.firmware import FirmwareVariant
from ..zwo.wire_values import MeridianSettings, MountMode
from .state import Persistent


class FlashSettings:
    """The settings stored in the mount, and the two that take effect only at the next power-up.

    Owns ``persist`` (what flash holds: it survives power cycles), ``mode_in_effect`` and
    ``ble_suffix`` (copied from flash by ``power_up``; ``:AA#`` or ``:SBl#`` change only flash).

    Lock: ``MountModel._lock``, lent as ``lock`` because the responder calls the public methods
    directly; they take it. ``power_up`` and reading the attributes are for callers that hold it.
    ``advance`` brings the model's physics up to the clock's present, so that a setting which
    changes motion (meridian, top speed) applies from now on, not retroactively.
    """

    def __init__(
        self,
        *,
        persist: Persistent,
        firmware: FirmwareVariant,
        lock: threading.RLock,
        advance: Callable[[], float],
    ) -> None:
        self.persist = persist
        self._firmware = firmware
        self._lock = lock
        self._advance = advance
        self.power_up()

    @property
    def keeps_site(self) -> bool:
        """Whether a site set by a client is written to flash (the ``site_in_flash`` variant)."""
        return self._firmware.site_in_flash

    def power_up(self) -> None:
        """The stored mode and Bluetooth suffix take effect (callers hold the lock)."""
        self.mode_in_effect = self.persist.mode
        self.ble_suffix = self.persist.ble_suffix

    # ---------------------------------------------------------------- meridian, limits, speed

    def set_meridian(self, settings: MeridianSettings) -> bool:
        if not -15 <= settings.limit_degrees <= 15:
            return False
        with self._lock:
            self._advance()
            self.persist.meridian = settings
            return True

    def meridian(self) -> MeridianSettings:
        with self._lock:
            return self.persist.meridian

    def set_limits_enabled(self, on: bool) -> None:
        with self._lock:
            self.persist.limits_enabled = on

    def limits_enabled(self) -> bool:
        with self._lock:
            return self.persist.limits_enabled

    def set_upper_limit(self, degrees: int) -> bool:
        if not 60 <= degrees <= 90:
            return False
        with self._lock:
            self.persist.upper_limit = degrees
            return True

    def set_lower_limit(self, degrees: int) -> bool:
        if not 0 <= degrees <= 30:
            return False
        with self._lock:
            self.persist.lower_limit = degrees
            return True

    def altitude_limits(self) -> tuple[int, int]:
        """(lower, upper) in degrees."""
        with self._lock:
            return self.persist.lower_limit, self.persist.upper_limit

    def set_max_speed(self, multiple: int) -> bool:
        """``:SRl#``: heavy-duty mode caps slews and moves at 720x instead of 1440x."""
        if multiple not in (720, 1440):
            return False
        with self._lock:
            self._advance()
            self.persist.max_speed = multiple
            return True

    def max_speed(self) -> int:
        with self._lock:
            return self.persist.max_speed

    # ---------------------------------------------------------------- mode, buzzer, identity

    def request_mode(self, mode: MountMode) -> None:
        """``:AP#``/``:AA#``: stored now, in effect after the next power-up (as on hardware)."""
        with self._lock:
            self.persist.mode = mode

    def mode(self) -> MountMode:
        """The mode in effect since the last power-up."""
        with self._lock:
            return self.mode_in_effect

    def set_buzzer(self, level: int) -> None:
        with self._lock:
            self.persist.buzzer = level

    def buzzer(self) -> int:
        with self._lock:
            return self.persist.buzzer

    def ble_name(self) -> str:
        with self._lock:
            return f"{self._firmware.model}_{self.ble_suffix}"

    def set_ble_suffix(self, suffix: str) -> bool:
        """Stored now, advertised after the next power-up."""
        if not (suffix.isascii() and suffix.isalnum() and 1 <= len(suffix) <= 12):
            return False
        with self._lock:
            self.persist.ble_suffix = suffix
            return True

    def ble_pair(self, pairing_id: str) -> bool:
        """``:BS#``: OK for a six-character id unless another device is already paired."""
        if len(pairing_id) != 6 or not pairing_id.isalnum():
            return False
        with self._lock:
            if self.persist.ble_paired not in (None, pairing_id):
                return False
            self.persist.ble_paired = pairing_id
            return True
