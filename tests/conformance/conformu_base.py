"""ConformU's DeviceTesterBaseClass: grading of exceptions, timing, and its wait primitives.

Everything here is a transcription of the base class (checklist §2, BASE L1811-L2198 and the
WaitFor/WaitWhile/TimeFunc helpers) so that a reply is graded exactly as ConformU grades it: the
same exception classes are OK in the same places, ``0x40B`` where ``0x401`` is expected gives the
extra ISSUE, a non-``ParkedException`` while parked is an ERROR, and so on.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import TypeVar

from tests.conformance.ascom import (
    INVALID_OPERATION,
    INVALID_VALUE,
    ConformTimeout,
    DriverException,
    EmulatedClock,
    InvalidOperationException,
    InvalidValueException,
    NotImplementedException,
    ParkedException,
    Stopwatch,
    ValueNotSetException,
    exception_name,
)
from tests.conformance.report import Report

T = TypeVar("T")


class MemberType(Enum):
    PROPERTY = "Property"
    METHOD = "Method"


class Required(Enum):
    OPTIONAL = "Optional"
    MANDATORY = "Mandatory"
    MUST_BE_IMPLEMENTED = "MustBeImplemented"
    MUST_NOT_BE_IMPLEMENTED = "MustNotBeImplemented"


class TargetTime(Enum):
    """Timing targets (GLB L37-L47); reported in the timing summary, never graded."""

    FAST = 0.1
    STANDARD = 1.0
    EXTENDED = 600.0


@dataclass(frozen=True)
class Timing:
    member: str
    seconds: float  # real seconds: HTTP service time does not speed up with the emulator
    target: TargetTime


SLEEP_TIME_MS = 500  # BASE: poll interval of the slewing / parking waits


class DeviceTesterBase:
    """The grading and waiting half of ConformU; subclasses hold the member-by-member sequence."""

    def __init__(self, report: Report, clock: EmulatedClock) -> None:
        self.report = report
        self.clock = clock
        self.timings: list[Timing] = []

    # -- logging --------------------------------------------------------------------------------------
    def log_ok(self, test: str, message: str) -> None:
        self.report.ok(test, message)

    def log_info(self, test: str, message: str) -> None:
        self.report.info(test, message)

    def log_issue(self, test: str, message: str) -> None:
        self.report.issue(test, message)

    def log_error(self, test: str, message: str) -> None:
        self.report.error(test, message)

    def log_debug(self, test: str, message: str) -> None:
        self.report.debug(test, message)

    # -- exception classification (BASE L1874-L2198) ---------------------------------------------------
    @staticmethod
    def is_not_implemented_exception(ex: BaseException) -> bool:
        return isinstance(ex, NotImplementedException)

    def is_invalid_value_exception(self, member: str, ex: BaseException) -> bool:
        if isinstance(ex, InvalidValueException):
            return True
        if isinstance(ex, InvalidOperationException):
            self.log_issue(member, "Received ASCOM.InvalidOperationException rather than ASCOM.InvalidValueException")
        elif isinstance(ex, DriverException) and ex.number == INVALID_VALUE:
            self.log_issue(member, f"Received ASCOM.DriverException(0x{INVALID_VALUE:X8}), please use "
                                   "ASCOM.InvalidValueException to report invalid values")
        return False

    def is_invalid_operation_exception(self, member: str, ex: BaseException) -> bool:
        if isinstance(ex, InvalidOperationException):
            return True
        if isinstance(ex, DriverException) and ex.number == INVALID_OPERATION:
            self.log_issue(member, f"Received ASCOM.DriverException(0x{INVALID_OPERATION:X8}), please use "
                                   "ASCOM.InvalidOperationException to report invalid operations")
        return False

    @staticmethod
    def is_not_set_exception(ex: BaseException) -> bool:
        return isinstance(ex, ValueNotSetException)

    def is_parked_exception(self, ex: BaseException) -> bool:
        """TT L5652-L5681: anything but a ParkedException is a Conform ERROR ("Unsupported exception")."""
        if isinstance(ex, ParkedException):
            return True
        self.log_error("IsParkedException", f"Unsupported exception: {type(ex).__name__} - {ex}")
        return False

    def handle_exception(self, member: str, member_type: MemberType, required: Required, ex: BaseException,
                         user_message: str) -> None:
        """BASE HandleException for an Alpaca device: 0x400 graded by ``required``, anything else an ISSUE."""
        if self.is_not_implemented_exception(ex):
            name = exception_name(ex)
            if required is Required.MANDATORY:
                self.log_issue(member, f"This member is mandatory but returned a {name} error, it must function "
                                       "per the ASCOM specification.")
            elif required is Required.MUST_NOT_BE_IMPLEMENTED:
                self.log_ok(member, f"{user_message} and a {name} error was generated as expected")
            elif required is Required.MUST_BE_IMPLEMENTED:
                self.log_issue(member, f"{user_message} and a {name} error was returned, this method must function "
                                       "per the ASCOM specification.")
            else:
                self.log_ok(member, f"Optional member returned a {name} error.")
        else:
            prefix = ":" if not user_message else f" - {user_message}:"
            self.log_issue(member, f"Unexpected error{prefix} {exception_name(ex)}: {ex}")
        self.log_debug(member, f"Exception detail: {ex!r}")

    def handle_invalid_value_exception_as_ok(self, member: str, member_type: MemberType, required: Required,
                                             ex: BaseException, user_action: str, message: str) -> None:
        if self.is_invalid_value_exception(member, ex):
            self.log_ok(member, message)
        else:
            self.handle_exception(member, member_type, required, ex, user_action)

    def handle_invalid_operation_exception_as_ok(self, member: str, member_type: MemberType, required: Required,
                                                 ex: BaseException, user_action: str, message: str) -> None:
        if self.is_invalid_operation_exception(member, ex):
            self.log_ok(member, message)
        else:
            self.handle_exception(member, member_type, required, ex, user_action)

    # -- timing -----------------------------------------------------------------------------------------
    def time_func(self, member: str, func: Callable[[], T], target: TargetTime) -> T:
        started = time.monotonic()
        try:
            return func()
        finally:
            self.timings.append(Timing(member, time.monotonic() - started, target))

    def time_method(self, member: str, func: Callable[[], object], target: TargetTime) -> None:
        self.time_func(member, func, target)

    # -- waiting (BASE WaitFor / WaitWhile, on the emulated clock) ----------------------------------------
    def wait_for(self, duration_ms: int, update_interval_ms: int = 500) -> None:
        """ConformU's WaitFor: sleep ``duration_ms`` (emulated) in update-interval steps."""
        if duration_ms <= 0:
            return
        interval = min(update_interval_ms, duration_ms)
        sw = Stopwatch(self.clock)
        while True:
            elapsed_ms = sw.elapsed * 1000.0
            loop = int((elapsed_ms + 50) // interval)
            sleep_ms = interval * (loop + 1) - elapsed_ms
            remaining = max(0.0, duration_ms - elapsed_ms)
            if remaining < interval:
                sleep_ms = remaining
            self.clock.sleep(sleep_ms / 1000.0)
            if sw.elapsed * 1000.0 > duration_ms:
                return

    def wait_while(self, action: str, wait_function: Callable[[], bool], poll_ms: int, timeout_s: float) -> None:
        """ConformU's WaitWhile: poll while the function is true; ConformTimeout after ``timeout_s``."""
        sw = Stopwatch(self.clock)
        while wait_function() and sw.elapsed < timeout_s:
            elapsed_ms = sw.elapsed * 1000.0
            loop = int((elapsed_ms + 50) // poll_ms)
            self.clock.sleep((poll_ms * (loop + 1) - elapsed_ms) / 1000.0)
        # ConformU re-reads once after the loop, and once more before declaring a timeout.
        if wait_function() and sw.elapsed >= timeout_s and wait_function():
            raise ConformTimeout(f'The "{action}" operation exceeded its {timeout_s:g} second timeout.')


# --- small numeric helpers ConformU uses --------------------------------------------------------------


def round_away(value: float, digits: int) -> float:
    """``Math.Round(value, digits, MidpointRounding.AwayFromZero)``."""
    scale = 10.0 ** digits
    return math.copysign(math.floor(abs(value) * scale + 0.5) / scale, value)


def condition_ra(ra: float) -> float:
    """``Utilities.ConditionRA``: into [0, 24)."""
    while ra < 0.0:
        ra += 24.0
    while ra >= 24.0:
        ra -= 24.0
    return ra


def ra_difference_arcsec(first: float, second: float) -> float:
    """``RaDifferenceInArcSeconds`` (TT): |Δ| with the 24 h wrap, as arcseconds rounded to 0.1."""
    difference = abs(first - second)
    if difference > 12.0:
        difference = 24.0 - difference
    return round_away(difference * 15.0 * 3600.0, 1)


def to_hms(hours: float) -> str:
    sign = "-" if hours < 0 else ""
    total = round(abs(hours) * 3600.0, 2)
    h, rem = divmod(total, 3600.0)
    m, s = divmod(rem, 60.0)
    return f"{sign}{int(h):02d}:{int(m):02d}:{s:05.2f}"


def to_dms(degrees: float) -> str:
    sign = "-" if degrees < 0 else ""
    total = round(abs(degrees) * 3600.0, 2)
    d, rem = divmod(total, 3600.0)
    m, s = divmod(rem, 60.0)
    return f"{sign}{int(d):02d}:{int(m):02d}:{s:05.2f}"
