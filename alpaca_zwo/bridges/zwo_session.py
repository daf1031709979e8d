"""One program's connection to the shared ZWO port: its session, and how a command is refused.

Apart from the command table (``zwo_replies``) so that the command groups (``zwo_clock_site``)
and the socket server (``zwo_port``) can name a session without importing the table.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from ..clients import ClientKey
from ..zwo.wire_values import SLEW_SPEEDS

__all__ = ["Handler", "Refusal", "Session"]


class Refusal(Exception):
    """A command the bridge refuses: ``reply`` is what the mount sends for such a refusal."""

    def __init__(self, reply: str | None, reason: str) -> None:
        super().__init__(reason)
        self.reply = reply
        self.reason = reason


@dataclass
class Session:
    """One connected program's view of the mount: its own target and move speeds.

    On the mount these are global, but programs sharing the port must not retarget each other's
    GOTO between ``:Sr``/``:Sd`` and ``:MS#``, so each gets its own.
    """

    key: ClientKey
    target: tuple[float, float] | None = None
    speed: float = SLEW_SPEEDS[9]  # multiple of sidereal; the mount powers up at :R9#
    axis_speed: list[float | None] = field(default_factory=lambda: [None, None])  # :Rvr/:Rvd
    moved_axes: set[int] = field(default_factory=set)  # axes this program set moving


Handler = Callable[[Session, str, bool], "str | None"]
