"""The ``RawCommands`` part alone on the real emulator: CommandBlind/Bool/String, off unless configured.

Over HTTP they answer 0x400 with the default configuration (tests/telescope/expectations.py's tables).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from alpaca_zwo._exceptions import ERR_MOUNT_PROTOCOL, DriverError, MemberNotImplemented, NotConnected
from alpaca_zwo.clients import ClientKey
from alpaca_zwo.config.settings import Settings
from alpaca_zwo.telescope.connection import Connection
from alpaca_zwo.telescope.raw_commands import RawCommands
from tests.conftest import make_settings
from tests.telescope.parts import Rig, parts_rig

CLIENT = ClientKey("192.0.2.40", 3)


def raw_allowed() -> Settings:
    base = make_settings()
    return dataclasses.replace(base, server=dataclasses.replace(base.server, allow_raw_commands=True))


def raw_and_connection(rig: Rig) -> tuple[RawCommands, Connection]:
    connection = rig.connection()
    return RawCommands(mount=rig.mount, settings=lambda: rig.settings,
                       require_connected=connection.require_connected), connection


def sent(rig: Rig, command: str) -> bool:
    return any(entry.request == command for entry in rig.mount.link.trace())


def test_off_by_default_and_nothing_reaches_the_mount(tmp_path: Path) -> None:
    with parts_rig(tmp_path) as rig:
        raw, connection = raw_and_connection(rig)
        connection.attach(CLIENT)
        for member in (raw.command_blind, raw.command_bool, raw.command_string):
            with pytest.raises(MemberNotImplemented, match="allow_raw_commands"):
                member(":Q#", True)
        assert not sent(rig, ":Q#")


def test_when_allowed_the_mount_answers(tmp_path: Path) -> None:
    with parts_rig(tmp_path, settings=raw_allowed()) as rig:
        raw, connection = raw_and_connection(rig)
        with pytest.raises(NotConnected):
            raw.command_string(":GVP#", True)
        connection.attach(CLIENT)
        assert raw.command_string(":GVP#", True) == "AM5"  # the reply without its terminator
        assert raw.command_bool(":GAT#", True) is False  # tracking is off at home: "0#"
        raw.command_blind(":GVP#", True)
        with pytest.raises(DriverError) as info:
            raw.command_bool(":GVP#", True)  # "AM5" is no boolean
        assert info.value.number == ERR_MOUNT_PROTOCOL
