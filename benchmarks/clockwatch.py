"""Whether the emulated universe and this computer's clock still keep together during a timed run.

The emulated universe runs on the monotonic clock, a server on this computer's wall clock. A virtual machine
paused (a snapshot) stands the monotonic clock still and steps the wall clock on resume; a run measured across
such a step is void (benchmarks/satellite.py's docstring). Kept apart from the benchmarks' process tools so
that its test needs nothing beyond the project's own test requirements.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from datetime import datetime
from typing import Any

#: A move of the emulated universe against this computer's clock beyond this (seconds) voids the run
#: (module docstring): 0.05 s is 3′ at the ISS's 1°/s overhead.
CLOCK_STEP_S = 0.05


class ClockWatch:
    """Reads the emulator's state and checks, on each reading, that the emulated universe and this
    computer's clock (the server's, libfaketime's offset apart) still keep together (module docstring)."""

    def __init__(self, emulator: Any, host_clock: Callable[[], float] = time.time) -> None:
        self.emulator = emulator
        self.host_clock = host_clock
        self.steps: list[dict[str, Any]] = []  # each: the universe's UTC and how far it moved (s)
        self.drift_s = 0.0  # how far the universe has moved against this computer's clock since the start
        self.offset_s = self._read()[1]  # the universe's UTC minus this computer's (s): the server's offset

    def _read(self) -> tuple[dict[str, Any], float, float]:
        """The state, the universe's UTC minus this computer's (seconds) taken in the middle of the control
        call, and the uncertainty of that (half the call)."""
        before = self.host_clock()
        state: dict[str, Any] = self.emulator.control("state")["state"]
        after = self.host_clock()
        universe = datetime.fromisoformat(state["true_utc"]).timestamp()
        return state, universe - (before + after) / 2.0, (after - before) / 2.0

    def state(self) -> dict[str, Any]:
        """The emulator's ``state``; a step of the clocks' relationship since the last one is noted."""
        state, offset, uncertainty = self._read()
        drift = offset - self.offset_s
        if abs(drift - self.drift_s) > CLOCK_STEP_S + uncertainty:
            self.steps.append({"utc": state["true_utc"], "step_s": round(drift - self.drift_s, 3)})
            print(f"the emulated universe moved {drift - self.drift_s:+.3f} s against this computer's clock "
                  f"at {state['true_utc']}: the run is void", file=sys.stderr, flush=True)
            self.drift_s = drift
        return state
