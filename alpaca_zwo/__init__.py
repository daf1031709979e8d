"""Alpaca server for ZWO AM3/AM5/AM7 mounts, and a faithful emulator of those mounts."""

from __future__ import annotations

__version__ = "0.1.0"
