"""The emulator frames requests with the shared :class:`alpaca_zwo.protocol.RequestFramer`."""

from __future__ import annotations

from ..protocol import RequestFramer as MountFramer

__all__ = ["MountFramer"]
