"""GOTOs that must land on a chosen pier side: a temporary meridian limit for one GOTO.

The mount chooses the pier side of a GOTO itself, from the target's hour angle and its meridian
setting (``:STa``; the evidence and the assumption are in docs/meridian.md), and has no command to
flip. So a SideOfPier write, and a GOTO that must keep pierEast past the meridian, write a meridian
limit under which the mount takes the wanted side, run the GOTO through the supervisor like any
other (horizon limits, aborts, landing, Slewing), and put the mount's own setting back when that
motion ends however it ends (arrived, aborted, replaced, failed). A GOTO that needs no temporary
setting restores a pending one first, so no other GOTO ever runs under it. If the link is gone
before the restore, the next connection writes the configured setting anyway
(``telescope.stored_settings.StoredSettings.push_configured``).

Lock: ``_lock`` serialises "write the setting, start the GOTO" against the restore, so a restore
owed to an earlier flip can never land between a new flip's setting and its GOTO. It is held across
serial I/O (two short exchanges) and is never taken by stop paths.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from .._exceptions import LinkError, MountReplyError, ProtocolError, driver_error
from ..mount.operations import Mount
from ..zwo.wire_values import MeridianSettings
from .kinds import MAX_MOTION_S, Motion
from .supervisor import MotionSupervisor

log = logging.getLogger(__name__)


def side_setting(limit_deg: int) -> MeridianSettings:
    """The ``:STa`` setting for a temporary limit: "track past" only where the limit is past the
    meridian (the mount refuses it at 0, and a negative limit ignores it)."""
    return MeridianSettings(False, limit_deg > 0, limit_deg)


class PierFlips:
    """Starts GOTOs under a temporary meridian setting and restores the mount's own afterwards."""

    def __init__(self, mount: Mount, motion: MotionSupervisor,
                 configured: Callable[[], MeridianSettings]) -> None:
        self.mount = mount
        self.motion = motion
        self._configured = configured  # the setting the mount keeps outside a flip
        self._lock = threading.Lock()
        self._in_force: Motion | None = None  # the motion a temporary setting was written for

    @property
    def in_force(self) -> bool:
        """A temporary setting is on the mount (tests and the status page may show it)."""
        return self._in_force is not None

    def goto(self, ra: float, dec: float, temporary: MeridianSettings | None) -> Motion:
        """Start a GOTO, under ``temporary`` until it ends if given (else under the mount's own)."""
        with self._lock:
            if temporary is not None:
                self.motion.interlock.require("SideOfPier")  # early: no temporary limit written for nothing
                self._write(temporary, "setting the meridian limit for a pier flip")
            elif self._in_force is not None:
                self._restore()
            try:
                motion = self.motion.goto(ra, dec)
            except BaseException:
                if temporary is not None:
                    self._restore()
                raise
            if temporary is not None:
                self._in_force = motion
                threading.Thread(target=self._restore_after, args=(motion,), name="pier-flip-restore",
                                 daemon=True).start()
            return motion

    def restore_now(self) -> None:
        """Put the mount's own setting back at once (before the link closes)."""
        with self._lock:
            if self._in_force is not None:
                self._restore()

    def _restore_after(self, motion: Motion) -> None:
        waited = 0.0
        while not motion.done.wait(1.0) and self.mount.running and waited < MAX_MOTION_S + 60.0:
            waited += 1.0
        with self._lock:
            if self._in_force is motion:  # not already restored or taken over by a newer flip
                self._restore()

    def _write(self, settings: MeridianSettings, what: str) -> None:
        try:
            self.mount.set_meridian(settings)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            raise driver_error(what, exc) from exc

    def _restore(self) -> None:
        """Callers hold ``_lock``."""
        self._in_force = None
        settings = self._configured()
        try:
            self.mount.set_meridian(settings)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            log.warning("could not restore the meridian setting %s after a pier flip (%s); the next "
                        "connection writes the configured one", settings, exc)
