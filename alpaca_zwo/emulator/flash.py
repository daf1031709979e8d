"""What the mount keeps in flash and exposes as settings: meridian, altitude limits, top speed, mode,
buzzer and Bluetooth identity (kept across power cycles and the ``reboot`` fault)."""

from __future__ import annotations

from ..zwo.wire_values import MeridianSettings, MountMode
from .state import ModelBase


class FlashSettings(ModelBase):
    """The settings stored in the mount, read and written through the model's lock."""

    # ---------------------------------------------------------------- meridian, limits, speed

    def set_meridian(self, settings: MeridianSettings) -> bool:
        if not -15 <= settings.limit_degrees <= 15:
            return False
        with self._lock:
            self._advance()
            self._persist.meridian = settings
            return True

    def meridian(self) -> MeridianSettings:
        with self._lock:
            return self._persist.meridian

    def set_limits_enabled(self, on: bool) -> None:
        with self._lock:
            self._persist.limits_enabled = on

    def limits_enabled(self) -> bool:
        with self._lock:
            return self._persist.limits_enabled

    def set_upper_limit(self, degrees: int) -> bool:
        if not 60 <= degrees <= 90:
            return False
        with self._lock:
            self._persist.upper_limit = degrees
            return True

    def set_lower_limit(self, degrees: int) -> bool:
        if not 0 <= degrees <= 30:
            return False
        with self._lock:
            self._persist.lower_limit = degrees
            return True

    def altitude_limits(self) -> tuple[int, int]:
        """(lower, upper) in degrees."""
        with self._lock:
            return self._persist.lower_limit, self._persist.upper_limit

    def set_max_speed(self, multiple: int) -> bool:
        """``:SRl#``: heavy-duty mode caps slews and moves at 720x instead of 1440x."""
        if multiple not in (720, 1440):
            return False
        with self._lock:
            self._advance()
            self._persist.max_speed = multiple
            return True

    def max_speed(self) -> int:
        with self._lock:
            return self._persist.max_speed

    # ---------------------------------------------------------------- mode, buzzer, identity

    def request_mode(self, mode: MountMode) -> None:
        """``:AP#``/``:AA#``: stored now, in effect after the next power-up (as on hardware)."""
        with self._lock:
            self._persist.mode = mode

    def mode(self) -> MountMode:
        with self._lock:
            return self._mode

    def set_buzzer(self, level: int) -> None:
        with self._lock:
            self._persist.buzzer = level

    def buzzer(self) -> int:
        with self._lock:
            return self._persist.buzzer

    def ble_name(self) -> str:
        with self._lock:
            return f"{self.firmware.model}_{self._ble_suffix}"

    def set_ble_suffix(self, suffix: str) -> bool:
        """Stored now, advertised after the next power-up."""
        if not (suffix.isascii() and suffix.isalnum() and 1 <= len(suffix) <= 12):
            return False
        with self._lock:
            self._persist.ble_suffix = suffix
            return True

    def ble_pair(self, pairing_id: str) -> bool:
        """``:BS#``: OK for a six-character id unless another device is already paired."""
        if len(pairing_id) != 6 or not pairing_id.isalnum():
            return False
        with self._lock:
            if self._persist.ble_paired not in (None, pairing_id):
                return False
            self._persist.ble_paired = pairing_id
            return True
