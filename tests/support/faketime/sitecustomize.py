"""Loaded (as ``sitecustomize``) only into a server run under Debian's faketime (tests/support/server.py).

libfaketime 0.9.10 cannot run Python 3.11 as it is: with the monotonic clock faked, every lock or
event timeout hangs (``sem_clockwait`` gets a faked deadline: wolfcw/libfaketime issue 390), and with
``FAKETIME_DONT_FAKE_MONOTONIC=1`` ``time.sleep`` fails with EINVAL (``clock_nanosleep`` with an
absolute monotonic deadline is converted wrongly: issue 426). The harness uses the second mode and
this module makes ``time.sleep`` an event wait, which sleeps the same on the real monotonic clock.
Only the wall clock stays faked, which is what the tests are about.
"""

from __future__ import annotations

import threading
import time

_never = threading.Event()


def _sleep(seconds: float) -> None:
    if seconds < 0:
        raise ValueError("sleep length must be non-negative")
    _never.wait(seconds)


time.sleep = _sleep
