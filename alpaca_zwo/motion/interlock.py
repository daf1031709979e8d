"""The observatory interlock's gate: may a motion start now, by what the safety monitor last said?

The supervisor asks it at every motion start (GOTO, Alt/Az slew, home, MoveAxis, PulseGuide, a rate
offset, Unpark, Tracking=true), so the rule holds for every door into the server (Alpaca, the page,
the Stellarium bridge, the shared ZWO port) without a check per caller. A park and every stop never
ask: they are how the mount is made safe. Who decides the verdict (polling the SafetyMonitor and the
roof) lives above, in ``alpaca_zwo/observatory``; this part only holds it.

The verdict is one immutable :class:`Verdict` replaced as a whole (a reference write is atomic), so
readers take no lock. Race rule: the observatory writes the new verdict *before* it stops or parks the
mount, and the supervisor asks the gate under its ``_lock`` in the same step that takes the stop
generation for the new motion; so a start racing the change is either refused or carries a
generation the stop withdraws. Tracking=true has no generation: its command carries :meth:`guard`,
which the link checks right before writing.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from enum import Enum

from .._exceptions import SafetyRefusal

__all__ = ["Interlock", "SafetyState", "Verdict"]


class SafetyState(Enum):
    OFF = "off"  # no monitor or roof configured: nothing is refused
    UNKNOWN = "unknown"  # configured, no answer yet (just started or reconfigured): motion waits for one
    SAFE = "safe"
    UNSAFE = "unsafe"


@dataclass(frozen=True)
class Verdict:
    """What the interlock says now and why.

    ``source``: the device whose answer decided (its URL), '' when off; ``reason``: that answer in words
    ("IsSafe=false", "ShutterStatus=1 (closed)", "no answer for 31 s: …"); ``since``: when this state
    began (UTC), None when off."""

    state: SafetyState = SafetyState.OFF
    source: str = ""
    reason: str = ""
    since: datetime | None = None

    @property
    def safe(self) -> bool:
        """Motion may start: no interlock configured, or its devices say safe."""
        return self.state in (SafetyState.OFF, SafetyState.SAFE)

    def describe(self) -> str:
        """One line for a refusal, the log and the page, always naming the safety monitor."""
        when = f" since {self.since:%H:%M:%S} UTC" if self.since is not None else ""
        if self.state is SafetyState.UNKNOWN:
            return f"the safety monitor has not answered yet ({self.reason}; {self.source})"
        if self.state is SafetyState.UNSAFE:
            return f"the safety monitor reports unsafe: {self.reason} ({self.source}){when}"
        if self.state is SafetyState.SAFE:
            return f"the safety monitor reports safe ({self.source}){when}"
        return "no safety monitor is configured"


class Interlock:
    """Holds the current :class:`Verdict` (shared by every telescope of a server); takes no lock."""

    def __init__(self) -> None:
        self.verdict = Verdict()

    def set(self, verdict: Verdict) -> Verdict:
        """Make ``verdict`` the current one; returns the one it replaced."""
        previous, self.verdict = self.verdict, verdict
        return previous

    def refusal(self, what: str) -> SafetyRefusal:
        verdict = self.verdict
        return SafetyRefusal(f"{what} refused: {verdict.describe()}. Park, AbortSlew, Tracking=false, syncs "
                             "and every read still work; motion is allowed again once it reports safe")

    def require(self, what: str) -> None:
        """Raise :class:`SafetyRefusal` (InvalidOperation 0x40B) unless motion may start now."""
        if not self.verdict.safe:
            raise self.refusal(what)

    def guard(self) -> Callable[[], bool]:
        """A link guard that holds while motion may start (checked right before a command is written)."""
        return lambda: self.verdict.safe
