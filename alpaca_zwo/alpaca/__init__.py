"""The Alpaca protocol layer: HTTP routing, parameters, replies and the management API.

It knows Alpaca and nothing of ZWO: a device is anything implementing :class:`AlpacaDevice`.
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
