"""The satellite benchmark voids a run whose clocks stepped apart (benchmarks/clockwatch.py, ``ClockWatch``).

The benchmark's server runs on this computer's wall clock (libfaketime moves it once, at the start) and the
emulated universe on the monotonic clock. On 2026-12-02 the virtual machine was paused three times during a
run (snapshots): the monotonic clock stood still, the wall clock was stepped on resume, the two drifted
8.8 s apart, and the server followed the satellite 8.8 s ahead of the emulated sky: a 14′ RMS second leg
that was no fault of the follow. Here the emulator is the real process; only the wall clock's step (which a
test cannot make the operating system do) is played by a clock the test steps.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from benchmarks.clockwatch import CLOCK_STEP_S, ClockWatch
from tests.support.emulator import EmulatorProcess


class SteppedWallClock:
    """This computer's wall clock, stepped by ``step`` (as a resumed virtual machine's is)."""

    def __init__(self) -> None:
        self.stepped_s = 0.0

    def __call__(self) -> float:
        return time.time() + self.stepped_s

    def step(self, seconds: float) -> None:
        self.stepped_s += seconds


@pytest.fixture(scope="module")
def emulator() -> Iterator[EmulatorProcess]:
    """One emulated mount (its own process) for the module: each test makes its own watch."""
    process = EmulatorProcess("--control-port", "0", "--baud", "0")
    yield process
    process.terminate()


def test_steady_clocks_leave_the_run_valid(emulator: EmulatorProcess) -> None:
    watch = ClockWatch(emulator, SteppedWallClock())
    for _ in range(5):
        watch.state()
    assert watch.steps == []


def test_a_wall_clock_step_is_reported_with_its_size(emulator: EmulatorProcess) -> None:
    wall = SteppedWallClock()
    watch = ClockWatch(emulator, wall)
    watch.state()
    wall.step(8.8)  # the VM resumed: the wall clock jumps, the emulated universe (monotonic) does not
    state = watch.state()
    watch.state()  # the new relationship holds: one step, not one per reading
    assert len(watch.steps) == 1, watch.steps
    assert watch.steps[0]["step_s"] == pytest.approx(-8.8, abs=CLOCK_STEP_S * 4)
    assert watch.steps[0]["utc"] == state["true_utc"]
