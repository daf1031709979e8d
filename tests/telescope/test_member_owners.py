"""The real Telescope against the member table: every row is answered by the part it names, with the
parameters and types the row says; a constant row is answered by the table alone; and the Telescope
keeps no one-line forwards to its parts (what the member table's owners replaced).

The Alpaca layer holds any device to the table when the app is built (``missing_handlers``); these tests
hold the Telescope to it before a server ever starts, types included, since the table is the only
declaration of the contract.
"""

from __future__ import annotations

import ast
import inspect
import textwrap
import typing
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path

import pytest

from alpaca_zwo.alpaca import ServerInfo, create_app
from alpaca_zwo.alpaca.device import handler_for, missing_handlers
from alpaca_zwo.alpaca.members import DEVICE_MEMBERS, ValueType
from alpaca_zwo.clients import ClientRegistry
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.mount.operations import Mount
from alpaca_zwo.telescope.capabilities import Capabilities
from alpaca_zwo.telescope.clock import SiteClock
from alpaca_zwo.telescope.connection import Connection
from alpaca_zwo.telescope.device import Telescope
from alpaca_zwo.telescope.raw_commands import RawCommands
from alpaca_zwo.telescope.targets import Targets
from alpaca_zwo.zwo.link import Link
from tests.conftest import make_settings
from tests.telescope.parts import closed_port

MEMBERS = DEVICE_MEMBERS["telescope"]
PYTHON_TYPES: dict[ValueType | None, object] = {
    ValueType.BOOL: bool, ValueType.INT: int, ValueType.FLOAT: float, ValueType.STR: str,
    ValueType.UTCDATE: datetime, ValueType.STR_LIST: list[str], ValueType.INT_LIST: list[int],
    ValueType.AXIS_RATES: list[tuple[float, float]], ValueType.DEVICE_STATE: list[tuple[str, object]],
    None: type(None),
}
#: The issue's bound on the Telescope's own surface (it had 107 public names, half of them forwards).
MAX_PUBLIC = 40


@pytest.fixture
def telescope(tmp_path: Path) -> Iterator[Telescope]:
    """A Telescope as server.py builds one; its mount never connects (nothing here needs it)."""
    store = SettingsStore(make_settings(), tmp_path / "config.toml")
    telescope = Telescope(Mount(Link(f"socket://127.0.0.1:{closed_port()}"), lambda: (0.0, 0.0)), store)
    yield telescope
    telescope.shutdown()


def test_every_row_is_answered_by_the_part_it_names(telescope: Telescope) -> None:
    assert missing_handlers(telescope, MEMBERS) == []
    parts = {m.owner: type(getattr(telescope, m.owner)) for m in MEMBERS if m.owner is not None}
    assert parts == {"connection": Connection, "capabilities": Capabilities, "clock": SiteClock,
                     "targets": Targets, "raw_commands": RawCommands}


def test_handlers_take_and_return_the_types_of_their_rows(telescope: Telescope) -> None:
    wrong = []
    for m in MEMBERS:
        if m.constant is not None:
            continue
        handler = handler_for(telescope, m)
        assert handler is not None, m.answered_by
        hints = typing.get_type_hints(handler)
        names = list(inspect.signature(handler).parameters)
        expected = ({names[0]: PYTHON_TYPES[m.params[0].type]} if m.setter
                    else {p.kwarg: PYTHON_TYPES[p.type] for p in m.params})
        expected["return"] = PYTHON_TYPES[m.returns]
        if hints != expected:
            wrong.append(f"{m.verb} {m.name} -> {m.answered_by}: {hints} instead of {expected}")
    assert not wrong, "\n".join(wrong)


def test_a_constant_row_has_no_handler_anywhere(telescope: Telescope) -> None:
    """A constant lives in the table alone: no method left behind on the Telescope or a part to drift from it."""
    holders = [telescope, *(getattr(telescope, owner) for owner in {m.owner for m in MEMBERS if m.owner})]
    left = [f"{type(h).__name__}.{m.handler}" for m in MEMBERS if m.constant is not None
            for h in holders if hasattr(h, m.handler)]
    assert not left


def test_a_handler_missing_from_its_part_stops_the_server(telescope: Telescope,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    def build() -> None:
        create_app([telescope], ClientRegistry(), ServerInfo("s", "m", "0", "l"))

    build()  # the real one serves
    monkeypatch.setattr(telescope.capabilities, "can_move_axis", lambda axes: True)  # a mis-named keyword
    with pytest.raises(TypeError, match=r"capabilities\.can_move_axis taking \['axis'\]"):
        build()
    monkeypatch.undo()
    monkeypatch.setattr(telescope, "targets", object())  # a part without its handlers
    with pytest.raises(TypeError, match=r"targets\.target_right_ascension"):
        build()


def _forwards(cls: type) -> list[str]:
    """Public methods whose whole body hands their own arguments to ``self.<part>.<method>``."""
    found = []
    for name, function in vars(cls).items():
        if name.startswith("_") or not inspect.isfunction(function):
            continue
        tree = ast.parse(textwrap.dedent(inspect.getsource(function))).body[0]
        assert isinstance(tree, ast.FunctionDef)
        body = [s for s in tree.body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))]
        if len(body) != 1 or not isinstance(body[0], (ast.Return, ast.Expr)):
            continue
        call = body[0].value
        if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)):
            continue
        target = call.func.value
        own = [a.arg for a in tree.args.args[1:]]
        passed = [a.id for a in call.args if isinstance(a, ast.Name)] + [
            k.value.id for k in call.keywords if isinstance(k.value, ast.Name)]
        if (isinstance(target, ast.Attribute) and isinstance(target.value, ast.Name) and target.value.id == "self"
                and passed == own and len(call.args) + len(call.keywords) == len(own)):
            found.append(f"{name} -> self.{target.attr}.{call.func.attr}")
    return found


def test_the_telescope_keeps_no_forwards() -> None:
    assert _forwards(Telescope) == []
    public = [name for name, value in vars(Telescope).items()
              if not name.startswith("_") and (inspect.isfunction(value) or isinstance(value, property))]
    assert len(public) <= MAX_PUBLIC, f"{len(public)} public names: {public}"


def test_the_forward_check_can_fail() -> None:
    class Forwarding:
        def __init__(self) -> None:
            self.clock = object()

        def utc_now(self) -> object:
            return self.clock.utc_now()  # type: ignore[attr-defined]

        def set_time(self, value: object, who: str) -> None:
            self.clock.set_time(value, who)  # type: ignore[attr-defined]

        def own_work(self, value: float) -> float:
            return self.clock.scale(value * 2)  # type: ignore[attr-defined]

    assert _forwards(Forwarding) == ["utc_now -> self.clock.utc_now", "set_time -> self.clock.set_time"]
