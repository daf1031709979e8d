"""What every test module shares: one Alpaca client, one waiter, one emulator process driver.

- :mod:`tests.support.alpaca`: :class:`AlpacaClient` (raw HTTP, decoded and timed calls, asserting
  helpers) and the :class:`Call`/:class:`CallLog` records the fault tests judge.
- :mod:`tests.support.wait`: :func:`wait_until`, polling a condition against a deadline.
- :mod:`tests.support.emulator`: :class:`EmulatorProcess`, ``python -m alpaca_zwo.emulator`` run
  as a subprocess with its endpoints and control channel.
"""

from __future__ import annotations

from tests.support.alpaca import AlpacaClient, Call, CallLog, local_url, next_ctid
from tests.support.emulator import EmulatorProcess
from tests.support.wait import wait_until

__all__ = ["AlpacaClient", "Call", "CallLog", "EmulatorProcess", "local_url", "next_ctid", "wait_until"]
