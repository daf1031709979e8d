"""Every real exchange in docs/firmware-evidence.md, replayed against the emulator preset of its firmware.

The document's replay tables are the test data: each row names a request, the exact reply bytes (a bare
``1``, a lone ``#``, or ``(no reply)``), the context the mount was in and the preset that answers as that
mount. Each row runs on a fresh emulator over its real TCP port, with the context built the way a client
would build it, and the bytes must match exactly, silences included (``MountClient.exact`` reads up to a
sentinel query, so a reply that should not be there shows up). The readings that cannot be compared byte
for byte (live clocks and positions) are checked here by their relation instead, as the document says.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from alpaca_zwo import sky
from alpaca_zwo.emulator import ManualClock, MountModel
from alpaca_zwo.zwo import wire_values
from alpaca_zwo.zwo.firmware import PRESETS, preset
from tests.emulator.emuclient import MountClient, initialize, slew, target_at

DOCUMENT = Path(__file__).resolve().parents[2] / "docs" / "firmware-evidence.md"
HEADER = "| Row | Request | Reply | Mount | Context | Preset | Source |"
NO_REPLY = "(no reply)"


@dataclass(frozen=True)
class Exchange:
    """One row of a replay table."""

    row: str
    request: str
    reply: str
    context: str
    preset: str


def _code(cell: str, what: str, row: str) -> str:
    match = re.fullmatch(r"`([^`]*)`", cell)
    if match is None:
        raise ValueError(f"row {row}: the {what} must be one code span, not {cell!r}")
    return match.group(1)


def _exchange(line: str) -> Exchange:
    cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
    row, request, reply, _mount, context, name = cells[:6]
    return Exchange(
        row=row,
        request=_code(request, "request", row),
        reply="" if reply == NO_REPLY else _code(reply, "reply", row),
        context=context,
        preset=name,
    )


def read_exchanges(text: str) -> list[Exchange]:
    """The rows of every table whose header is :data:`HEADER`, in document order."""
    rows: list[Exchange] = []
    in_table = False
    for line in text.splitlines():
        if line.strip() == HEADER:
            in_table = True
        elif in_table and line.startswith("|---"):
            continue
        elif in_table and line.startswith("| "):
            rows.append(_exchange(line))
        else:
            in_table = False
    return rows


EXCHANGES = read_exchanges(DOCUMENT.read_text(encoding="utf-8"))

# ------------------------------------------------------------------------------------------ contexts

Setup = Callable[[MountClient, MountModel, ManualClock], None]


def _set_up(client: MountClient, model: MountModel, clock: ManualClock) -> None:
    initialize(client, clock)


def _tracking(client: MountClient, model: MountModel, clock: ManualClock) -> None:
    _set_up(client, model, clock)
    slew(client, clock, target_at(model, -2.0), 40.0)


def _target_here(client: MountClient, model: MountModel, clock: ManualClock) -> None:
    _tracking(client, model, clock)
    assert client.exact(f":Sr{client.ask(':GR#').rstrip('#')}#") == "1"
    assert client.exact(f":Sd{client.ask(':GD#').rstrip('#')}#") == "1"


def _parked(client: MountClient, model: MountModel, clock: ManualClock) -> None:
    _set_up(client, model, clock)
    assert client.exact(":hP#") in ("", "1#")  # silent on 1.8.8
    for _ in range(240):
        if client.ask(":Gps#") == "2#":
            return
        clock.advance(0.5)
    raise AssertionError("the park did not end")


def _parked_power_cycled(client: MountClient, model: MountModel, clock: ManualClock) -> None:
    _parked(client, model, clock)
    model.power_cycle()  # what the control port's reboot does (test_emulator_firmware_park.py goes through it)


def _limits_on(client: MountClient, model: MountModel, clock: ManualClock) -> None:
    _set_up(client, model, clock)
    assert client.exact(":SLE#") == "1"


def _low_target(client: MountClient, model: MountModel, clock: ManualClock) -> None:
    """The target on the meridian 9° up, under a 10° floor: Dec = latitude - 81° (north)."""
    _set_up(client, model, clock)
    assert client.exact(":SLL10#") == "1"
    assert client.exact(":SLE#") == "1"
    latitude = wire_values.parse_dms(client.ask(":Gt#").rstrip("#"))
    assert client.exact(f":Sr{wire_values.format_hms(target_at(model, 0.0))}#") == "1"
    assert client.exact(f":Sd{wire_values.format_dms(latitude - 81.0)}#") == "1"


CONTEXTS: dict[str, Setup] = {
    "power-up": lambda client, model, clock: None,
    "set up": _set_up,
    "tracking": _tracking,
    "tracking, target here": _target_here,
    "parked": _parked,
    "parked, power-cycled": _parked_power_cycled,
    "limits on": _limits_on,
    "target 9° high, floor 10°": _low_target,
}

# ------------------------------------------------------------------------------------------ the replay


def test_the_document_has_its_tables() -> None:
    """A broken table would silently replay nothing: the rows are there, unique, and name what exists."""
    assert len(EXCHANGES) >= 60
    rows = [exchange.row for exchange in EXCHANGES]
    assert len(rows) == len(set(rows))
    for exchange in EXCHANGES:
        assert exchange.context in CONTEXTS, exchange.row
        assert exchange.preset in PRESETS, exchange.row
        assert exchange.request.startswith(":") and exchange.request.endswith("#"), exchange.row


@pytest.mark.parametrize(
    ("exchange", "firmware"),
    [(exchange, preset(exchange.preset)) for exchange in EXCHANGES],
    ids=[f"{exchange.row}-{exchange.request}" for exchange in EXCHANGES],
)
def test_the_emulator_answers_as_the_real_mount(
    exchange: Exchange, mount: MountClient, model: MountModel, clock: ManualClock,
) -> None:
    CONTEXTS[exchange.context](mount, model, clock)
    assert mount.exact(exchange.request) == exchange.reply


# ------------------------------------------------------------------------------------------ relations

REAL = [preset("am5-1.8.8"), preset("am5n-1.8.8")]


def _hours(reply: str) -> float:
    return wire_values.parse_hms(reply.rstrip("#"))


@pytest.mark.parametrize("firmware", REAL, ids=lambda f: f.name)
@pytest.mark.parametrize("context", ["power-up", "set up", "parked, power-cycled"])
def test_home_reads_the_hour_angle_plus_6h(
    context: str, mount: MountClient, model: MountModel, clock: ManualClock,
) -> None:
    """At home in the north, RA = LST - 6 h (S1: `10:13:56#` against `16:13:58#`), Dec +90, pier E."""
    CONTEXTS[context](mount, model, clock)
    lst, ra = _hours(mount.ask(":GS#")), _hours(mount.ask(":GR#"))
    assert sky.wrap_hours_12(lst - ra - 6.0) == pytest.approx(0.0, abs=1.5 / 3600)
    assert (mount.ask(":GD#"), mount.ask(":Gm#"), mount.ask(":GZ#")) == ("+90*00:00#", "E#", "360*00:00#")


@pytest.mark.parametrize("firmware", REAL, ids=lambda f: f.name)
def test_status_word_letters_and_state_digit(mount: MountClient, model: MountModel, clock: ManualClock) -> None:
    """S2's `NGM011000211#` while tracking: the letters and the state digit; the middle digits are not modelled."""
    _tracking(mount, model, clock)
    word = mount.ask(":GU#")
    assert re.fullmatch(r"NGM\d{8}1#", word), word


@pytest.mark.parametrize("firmware", REAL, ids=lambda f: f.name)
def test_gast_is_three_records(mount: MountClient, model: MountModel, clock: ManualClock) -> None:
    """`:GAST#`: date&time&zone, RA&Dec and the status word, each ending in `#`, in one reply (S2 doc L632)."""
    _tracking(mount, model, clock)
    reply = mount.exact(":GAST#")
    records = reply.split("#")
    assert len(records) == 4 and records[3] == "", reply
    assert re.fullmatch(r"\d\d/\d\d/\d\d&\d\d:\d\d:\d\d&[+-]\d\d:\d\d", records[0]), reply
    assert re.fullmatch(r"\d\d:\d\d:\d\d&[+-]\d\d\*\d\d:\d\d", records[1]), reply
    assert re.fullmatch(r"NGM\d{8}1", records[2]), reply
    assert records[1] == mount.ask(":GR#").rstrip("#") + "&" + mount.ask(":GD#").rstrip("#")


@pytest.mark.parametrize("firmware", REAL, ids=lambda f: f.name)
def test_aliases(mount: MountClient, model: MountModel, clock: ManualClock) -> None:
    """`:GRr#`/`:GDr#` answer what `:GR#`/`:GD#` answer (S2 doc L633); the clock is still, so the reads agree."""
    _tracking(mount, model, clock)
    assert mount.exact(":GRr#") == mount.exact(":GR#")
    assert mount.exact(":GDr#") == mount.exact(":GD#")


@pytest.mark.parametrize("firmware", [preset("am5n-1.8.8")], ids=lambda f: f.name)
@pytest.mark.parametrize(("speed", "multiple"), [(1, 0.5), (3, 1.9), (5, 7.8), (7, 60.0)])
def test_measured_jog_rates(
    speed: int, multiple: float, mount: MountClient, model: MountModel, clock: ManualClock,
) -> None:
    """S1 measured R3 1.9x, R5 7.8x, R7 60x sidereal on an AM5N 1.8.8, and R1 0.5x over 10 s (its table's
    0.3x conflicts; docs/firmware-evidence.md): the steady speed of a move."""
    _set_up(mount, model, clock)
    slew(mount, clock, target_at(model, -2.0), 40.0)
    assert mount.exact(":Td#") == "1"
    mount.send(f":R{speed}#")
    mount.send(":Mn#")
    clock.advance(5.0)  # past the acceleration ramp
    before = model.axes()[1]
    clock.advance(10.0)
    rate = abs(model.axes()[1] - before) / 10.0
    mount.send(":Q#")
    assert rate == pytest.approx(multiple * sky.SIDEREAL_DEG_S, rel=1e-6)
