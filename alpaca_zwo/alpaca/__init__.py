"""The Alpaca front door: HTTP routing, parameters, replies, errors and the management API.

Owns the falcon app and the member table, strict parameters, rendering, waitress with its
per-address connection limit, UDP discovery (32227), the mDNS advertiser, the DNS-rebinding host
guard, and how clients reach this machine (``listen_check``: can we listen on a host and port;
``local_addresses``: this machine's LAN addresses for the start banner). Also the other way round, as a
client of other Alpaca devices: ``remote`` (reading a SafetyMonitor or a Dome) and ``finder`` (discovering
them for the setup page). It knows Alpaca and nothing of ZWO: a device is an :class:`AlpacaDevice` (its
identity) with the handlers the member table names, each on the part of the device the row says.

May import only ``clients`` and ``_exceptions``.
"""

from __future__ import annotations

from alpaca_zwo.alpaca.app import create_app
from alpaca_zwo.alpaca.device import AlpacaDevice
from alpaca_zwo.alpaca.http import HttpServer
from alpaca_zwo.alpaca.management import ServerInfo
from alpaca_zwo.alpaca.members import DEVICE_MEMBERS, TELESCOPE_DEVICE_STATE, Member, Param, ValueType
from alpaca_zwo.alpaca.params import BadRequest
from alpaca_zwo.alpaca.render import format_utc_date

__all__ = [
    "DEVICE_MEMBERS",
    "TELESCOPE_DEVICE_STATE",
    "AlpacaDevice",
    "BadRequest",
    "HttpServer",
    "Member",
    "Param",
    "ServerInfo",
    "ValueType",
    "create_app",
    "format_utc_date",
]
