"""Every ZWO command, well formed and malformed, asked of the emulator and of the shared ZWO port.

The script (:func:`script`) holds every command of ``zwo/protocol.py``'s table in its good forms,
its malformed forms (bad values, bad shapes, a sign too many, trailing text) and unknown or
miscased codes, in an order that walks the mount through its states: site and clock set, GOTOs,
moves, tracking, guiding, syncs, home, park, meridian and limits, identity. After every command
that is not a plain query the replies of :data:`PROBES` (most of the mount's readings) are
recorded too, so a command's effect is captured as well as its reply.

A capture runs on an emulator with a ``ManualClock``: time moves only at the script's ``@advance``
steps, so the same script gives the same bytes on every run. The shared port is captured the same
way, over its real socket, on a Telescope whose clock is that emulator's universe
(:func:`capture_port`). ``tests/emulator/test_responder_replies.py`` and
``tests/bridges/test_zwo_port_replies.py`` compare captures with the JSON files recorded before the
ZWO command set was put in one table (issue 34); ``python -m tests.support.zwo_capture`` writes them
again (only when a change of the mount's answers is intended, and reviewed).
"""

from __future__ import annotations

import json
import os
import socket
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from alpaca_zwo.zwo import protocol

ROOT = Path(__file__).resolve().parents[2]
EMULATOR_FILE = ROOT / "tests" / "emulator" / "responder_replies.json"
PORT_FILE = ROOT / "tests" / "bridges" / "zwo_port_replies.json"

#: A fixed start of the emulated universe: a March evening in UTC.
START_UTC = datetime(2025, 3, 20, 20, 0, 0, tzinfo=timezone.utc)
SOUTH = (-33.8568, 151.2153)  # Sydney
NORTH = (51.4769, -0.0005)  # Greenwich

#: The readings recorded after every command that is not a query.
PROBES = ("GR", "GD", "Gr", "Gd", "GS", "GC", "GL", "GG", "GH", "Gt", "Gg", "GU", "GAT", "GT", "Ggr", "Gm",
          "GTa", "GLC", "GLH", "GLL", "GRl", "GBu", "Gps", "Gh", "GA", "GZ", "GMZA", "GMTI", "GV", "GVP")

#: Queries: asked once each at the start, in every form.
QUERIES = [c.code for c in protocol.COMMANDS if c.kind is protocol.ReplyKind.TEXT and c.args is None]

#: Commands with arguments: good forms first, then malformed ones.
ARGUMENTS: dict[str, list[str]] = {
    "SC": ["03/21/25", "12/31/24", "03/20/25", "13/45/25", "02/30/25", "3/21/25", "03-21-25", ""],
    "SL": ["21:30:00", "20:00:05", "25:00:00", "12:60:00", "1:02:03", "21:30", ""],
    "SG": ["-08", "+05:30", "+00", "+00:00", "5", "+15", "-14:30", "+5:3", "+05:3", "++05", ""],
    "St": ["+45*30:00", "-33*52:00", "+51*28:37", "+95*00:00", "45*30", "+45\xdf30:00", "abc", ""],
    "Sg": ["-151*12:00", "+000*00:02", "+190*00:00", "-010*30", "east", ""],
    "SMTI": ["03/20/25&20:00:00&+00:00", "03/20/25&21:00:00&-01:00", "02/30/25&20:00:00&+00:00",
             "03/20/25&20:00:00", "03/20/25&20:00:00&+5", "x&y&z"],
    "SMGE": ["+51*28:37&+000*00:02", "-33*51:24&-151*12:55", "+45*00:00&+200*00:00", "+45*00:00", "a&b"],
    "SS": ["12:00:00", "23:59:59", "99:00:00", "1:2:3", "abc"],
    "SH": ["1", "0", "2", "10", ""],
    "Sr": ["05:34:32", "05:34.5", " 05:34:32", "24:00:00", "05:60:00", "5:34:32", "abc", ""],
    "Sd": ["+22*00:52", "-45*30:00", "+22\xdf00:52", "+22*00", "22*00:52", "+95*00:00", "-90*00:01", "abc", ""],
    "SMeq": ["05:34:32&+22*00:52", "05:34:32&+95*00:00", "05:34:32", "x&y"],
    "SMMC": ["05:34:32&+22*00:52", "05:34:32&+95*00:00", "05:34:32", "x&y"],
    "R": ["0", "5", "9", "a", "10", ""],
    "Rv": ["1.5", "720", "1440", "2000", "0.05", "-1", "1.555", "x"],
    "Rvr": ["2.5", "100", "1440.00", "9999", "x"],
    "Rvd": ["3", "600.5", "1500", "-3", "x"],
    "STR": ["10", "05", "1", "abc"],
    "Mg": ["n0500", "s0100", "e0250", "w9999", "n00001", "x0100", "n", "n123456"],
    "Rg": ["0.5", "0.90", "0.1", "7.5", "13.5", "1.0", "14", "0.05", "abc"],
    "STa": ["00+00", "01+10", "11-05", "01-15", "00+5", "01+20", "2x+00", "00+000", ""],
    "SLH": ["80", "90", "60", "55", "+80", "8", "100", ""],
    "SLL": ["10", "00", "30", "35", "-5", "5", "+10", ""],
    "SRl": ["720", "1440", "999", "12", "x"],
    "SBu": ["0", "1", "2", "3", "x", ""],
    "SBl": ["ABC123", "Z", "TOOLONGNAME1234", "!!", ""],
    "BS": ["1234", "ABCD", "!!", ""],
}


def _with_arguments(code: str) -> list[str]:
    return [code + argument for argument in ARGUMENTS[code]]


def segments() -> dict[str, list[str]]:
    """The script: request bodies (text between ``:`` and ``#``) in segments, each run on a fresh mount.

    Within a segment time stands still on the port (the Telescope's clock is the emulator's frozen
    universe), so a motion started there never ends and every reading stays put: what a command
    answers and changes is the same on every run. ``@advance S`` moves the emulator's clock S
    seconds in the emulator's own captures (a GOTO ends, a move covers ground); the port's
    captures skip it."""
    settings: list[str] = list(QUERIES)
    for code in ("SG", "SC", "SL", "SMTI", "St", "Sg", "SMGE", "SH", "SS"):
        settings += _with_arguments(code)
    settings += ["SMTI03/20/25&20:00:00&+00:00", "SH0"]
    settings += _with_arguments("Sr") + _with_arguments("Sd")
    settings += _with_arguments("R")
    for code in ("RG", "RC", "RM", "RS"):
        settings += [code, code + "x"]
    settings += _with_arguments("Rv") + _with_arguments("Rvr") + _with_arguments("Rvd")
    settings += ["TQ", "GT", "TS", "GT", "TL", "GT", "TQ", "TQx", *_with_arguments("STR")]
    settings += ["Td", "GAT", "Te", "GAT", "Tex", "Tdx"]
    settings += [*_with_arguments("Rg"), "Rg0.5"]
    for code in ("STa", "SLH", "SLL", "SRl", "SBu"):
        settings += _with_arguments(code)
    settings += ["STa00+00", "SLE", "SLD", "SLEx", "SLH80", "SLL05", "SRl1440", "SBu1"]
    settings += ["GV", "GVx", "GVP", "GVT", "GBl", "GU", *_with_arguments("SBl"), *_with_arguments("BS")]
    settings += ["AA", "AP", "AAx", "APx", "Gh", "SOax", "Spux", "hCx", "hPx", "CMx", "NSCx", "Mex", "Qex", "Mx"]
    settings += ["GX", "gr", "STA00+00", "", " ", "G", "S", "M", "Xyz", "GRGD", "GR ", "sr05:00:00", "\xdf"]
    # Syncs at rest, alignment, home and park positions; then a GOTO under the horizon in the north
    # (refused; it starts in the south) and the compound forms (e2#, or a GOTO and a sync on firmware
    # that has them).
    settings += ["Te", "Sr05:00:00", "Sd+20*00:00", "CM", "Sr05:00:10", "Sd+20*01:00", "CM", "NSC", "SOa",
                 "Sp01", "Spu", "Gps", "Sr12:00:00", "Sd-80*00:00", "MS"]
    settings += _with_arguments("SMMC") + _with_arguments("SMeq")
    # (No GOTO after the stop: on the port's frozen clock the axes never finish braking, so it would
    # wait for them in vain.)
    goto = ["Te", "Sr03:00:00", "Sd+60*00:00", "MS", "MS", "CM", "Gm", "@advance 1", "GU", "Q", "@advance 60",
            "GU", "Gm"]
    moves = ["R5", "Me", "@advance 1", "Qe", "@advance 5", "Mw", "@advance 1", "Qw", "@advance 5", "Mn",
             "@advance 1", "Qn", "@advance 5", "Ms", "@advance 1", "Qs", "@advance 5", "Rv2", "Me", "Mn",
             "@advance 2", "Q", "@advance 30", "Rvr3", "Rvd4", "Mw", "Ms", "@advance 2", "Qw", "Qs"]
    guiding = ["Te", "Rg0.5", *_with_arguments("Mg"), "@advance 12", "Td", "Mgn0500", "Mge0500"]
    home = ["hC", "Gh", "SOa", "Sp01", "@advance 90", "Gh", "GU", "SOa", "Sp01", "Gm"]
    park = ["hP", "Gps", "Spu", "@advance 5", "Gps", "@advance 90", "Gps", "Sr02:00:00", "Sd+30*00:00", "MS",
            "Te", "Spu", "Spu", "Gps", "Sp01"]
    script = {"settings": settings, "goto": goto, "moves": moves, "guiding": guiding, "home": home, "park": park}
    steps = [step for segment in script.values() for step in segment]
    missing = {c.code for c in protocol.COMMANDS} - {_code(step) for step in steps}
    assert not missing, f"the capture script misses {sorted(missing)}"
    return script


def _code(step: str) -> str:
    match = protocol.match_command(step)
    return match.command.code if match else ""


def _is_query(body: str) -> bool:
    match = protocol.match_command(body)
    return match is not None and match.well_formed and match.command.kind is protocol.ReplyKind.TEXT \
        and match.command.code.startswith("G")


# --------------------------------------------------------------------------------------------
# The wire: one request, then a sentinel whose reply marks the end of the request's
# --------------------------------------------------------------------------------------------


class Wire:
    """A program on a ZWO-protocol socket. Requests on one connection are answered in order, so the
    reply to a request is whatever arrives before the sentinel query's reply (``:GVP#``: both the
    emulator and the port answer it)."""

    def __init__(self, port: int, sentinel_reply: bytes) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=30)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sentinel_reply = sentinel_reply

    def ask(self, bodies: list[str]) -> str:
        """The replies to ``bodies`` sent back to back, as one string."""
        text = "".join(f":{body}#" for body in bodies) + ":GVP#"
        self.sock.sendall(text.encode("latin-1"))
        expected = 1 + sum(1 for body in bodies if body == "GVP")
        data = b""
        while data.count(self.sentinel_reply) < expected or not data.endswith(self.sentinel_reply):
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError(f"closed after {data!r}")
            data += chunk
        return data[:-len(self.sentinel_reply)].decode("latin-1")

    def close(self) -> None:
        self.sock.close()


@dataclass
class Capture:
    """One configuration's record: for each step, the request, its reply and (after a command) the probes."""

    name: str
    rows: list[dict[str, Any]] = field(default_factory=list)

    def add(self, step: str, reply: str | None = None, probes: str | None = None, **extra: Any) -> None:
        row: dict[str, Any] = {"request": step}
        if reply is not None:
            row["reply"] = reply
        if probes is not None:
            row["probes"] = probes
        row.update(extra)
        self.rows.append(row)


def _run(capture: Capture, segment: str, steps: list[str], wire: Wire, advance: Callable[[float], None] | None,
         settle: Callable[[], None] = lambda: None, refused: Callable[[], int] | None = None) -> None:
    last_probes = None
    for step in steps:
        if step.startswith("@advance"):
            if advance is not None:
                advance(float(step.split()[1]))
                capture.add(f"{segment}: {step}")
            continue
        before = refused() if refused is not None else 0
        reply = wire.ask([step])
        extra: dict[str, Any] = {}
        if refused is not None and refused() != before:
            extra["refused"] = True
        probes = None
        if not _is_query(step):
            settle()
            probes = wire.ask(list(PROBES))
            if probes == last_probes:
                probes = None  # unchanged: recorded once, where it changed
            else:
                last_probes = probes
        capture.add(f"{segment}: {step}", reply, probes, **extra)


# --------------------------------------------------------------------------------------------
# The emulator
# --------------------------------------------------------------------------------------------

EMULATOR_CONFIGS: dict[str, dict[str, Any]] = {
    "am5-north-eq": {"preset": "am5-1.9.2", "site": NORTH},
    "am5-south-eq": {"preset": "am5-1.9.2", "site": SOUTH},
    "am5-north-altaz": {"preset": "am5-1.9.2", "site": NORTH, "altaz": True},
    "am5-south-altaz": {"preset": "am5-1.9.2", "site": SOUTH, "altaz": True},
    "am5n-1.6.3-north": {"preset": "am5n-1.6.3", "site": NORTH},
    "am5-1.8.8-south": {"preset": "am5-1.8.8", "site": SOUTH},
    "am5n-1.8.8-north": {"preset": "am5n-1.8.8", "site": NORTH},
    "am5-x2-north": {"preset": "am5-x2", "site": NORTH},
    "am3-1.6.3-south": {"preset": "am3-1.6.3", "site": SOUTH},
    "am7-2.0.0-north-altaz": {"preset": "am7-2.0.0", "site": NORTH, "altaz": True},
    # The switches no preset turns on: compound GOTO/sync, custom rates, Chinese :GT# digits, :Gh#
    # that tells, mechanical pier letters, firmware without the meridian settings.
    "variants-north": {"switches": {"compound_goto_sync": True, "custom_tracking": True, "gt_mapping": "chinese",
                                    "gh_reply": "homed", "pier_letter": "mechanical", "version": "1.2.0"},
                       "site": NORTH},
    "variants-south": {"switches": {"compound_goto_sync": True, "custom_tracking": True, "gh_reply": "homed",
                                    "pier_letter": "hour_angle", "ns_moves": "mechanical", "site_in_flash": True},
                       "site": SOUTH},
}


def _firmware(config: dict[str, Any]) -> Any:
    from alpaca_zwo.zwo.firmware import FirmwareVariant, preset

    if "switches" in config:
        return FirmwareVariant(**config["switches"])
    # The record is of what the mount answers, one request at a time: a busy 1.8.8 mount's late
    # acknowledgement (ack_while_slewing) would land in whichever later reply is open when its slew
    # ends. Its timing is tested where it matters, tests/zwo/test_late_acks.py.
    return preset(config["preset"], ack_while_slewing="prompt")


def _model(config: dict[str, Any], clock: Any, initialized: bool) -> Any:
    from alpaca_zwo.emulator import MountModel
    from alpaca_zwo.zwo.wire_values import MountMode

    mode = MountMode.ALTAZ if config.get("altaz") else MountMode.EQUATORIAL
    return MountModel(clock, _firmware(config), site=config["site"], initialized=initialized, mode=mode)


def capture_emulator(name: str) -> Capture:
    """The emulator's answers to the script, in configuration ``name`` (a fresh mount per segment)."""
    from alpaca_zwo.emulator import EmulatorServer, ManualClock

    config = EMULATOR_CONFIGS[name]
    capture = Capture(name)
    for segment, steps in segments().items():
        clock = ManualClock(START_UTC)
        model = _model(config, clock, initialized=True)
        with EmulatorServer(model, host="127.0.0.1", port=0, baud=0) as server:
            wire = Wire(server.port, f"{model.firmware.model}#".encode())
            try:
                _run(capture, segment, steps, wire, clock.advance)
            finally:
                wire.close()
    return capture


# --------------------------------------------------------------------------------------------
# The shared ZWO port, on a Telescope driving that emulator
# --------------------------------------------------------------------------------------------

PORT_CONFIGS: dict[str, dict[str, Any]] = {
    "north-eq-guarded": {"preset": "am5-1.9.2", "site": NORTH},
    "north-eq-allowed": {"preset": "am5-1.9.2", "site": NORTH, "allow": ("all",)},
    "south-eq-allowed": {"preset": "am5-1.9.2", "site": SOUTH, "allow": ("all",)},
    "south-eq-guarded": {"preset": "am5-1.9.2", "site": SOUTH},
    "north-altaz-allowed": {"preset": "am5-1.9.2", "site": NORTH, "altaz": True, "allow": ("all",)},
    "south-altaz-some": {"preset": "am5-1.9.2", "site": SOUTH, "altaz": True, "allow": ("STa", "SBu", "SS")},
    "old-firmware-north-allowed": {"switches": {"version": "1.2.0"}, "site": NORTH, "allow": ("all",)},
}


@contextmanager
def _utc_zone() -> Iterator[None]:
    """The host on UTC, so the capture is the same on every host: the port starts with the mount's zone, the
    site's (Sydney +11 in March), and falls back to the host's only where the site's is unknown."""
    saved = os.environ.get("TZ")
    os.environ["TZ"] = "UTC"
    time.tzset()
    try:
        yield
    finally:
        if saved is None:
            del os.environ["TZ"]
        else:
            os.environ["TZ"] = saved
        time.tzset()


@contextmanager
def _restored(module: Any, values: dict[str, Any]) -> Iterator[None]:
    try:
        yield
    finally:
        for name, value in values.items():
            setattr(module, name, value)


def _wait(condition: Callable[[], object], what: str, timeout: float = 30.0) -> None:
    from tests.support.wait import wait_until

    wait_until(condition, timeout, what)


def capture_port(name: str) -> Capture:
    """The shared port's answers to the script, in configuration ``name``: a fresh Telescope per
    segment (its clock the emulator's ``ManualClock``) on an unpaced emulator, the port on a free
    loopback port, asked over its socket."""
    from alpaca_zwo.bridges import zwo_port

    capture = Capture(name)
    # The script sends its probes far faster than a driver: lift the port's flood limits for it.
    limits = {name: getattr(zwo_port, name) for name in ("COMMAND_RATE", "COMMAND_BURST", "BYTE_RATE", "BYTE_BURST")}
    for limit in limits:
        setattr(zwo_port, limit, 1e9)
    with _restored(zwo_port, limits), _utc_zone():
        for segment, steps in segments().items():
            _capture_port_segment(capture, PORT_CONFIGS[name], segment, steps)
    return capture


def _capture_port_segment(capture: Capture, config: dict[str, Any], segment: str, steps: list[str]) -> None:
    from alpaca_zwo.bridges.zwo_port import ZwoPortBridge
    from alpaca_zwo.clients import ClientRegistry
    from alpaca_zwo.config.settings import SiteSettings, TimeSettings, ZwoPortSettings
    from alpaca_zwo.config.store import SettingsStore
    from alpaca_zwo.emulator import EmulatorServer, ManualClock
    from alpaca_zwo.motion.interlock import Interlock
    from alpaca_zwo.mount.host_clock import HostClockWatch
    from alpaca_zwo.mount.operations import Mount
    from alpaca_zwo.mount.timekeeping import TimeKeeper
    from alpaca_zwo.telescope.device import Telescope
    from alpaca_zwo.zwo.link import Link
    from tests.conftest import make_settings

    latitude, longitude = config["site"]
    settings = make_settings(site=SiteSettings(latitude=latitude, longitude=longitude, elevation=10.0),
                             time=TimeSettings(source="host"),
                             zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0,
                                                      allow_dangerous=config.get("allow", ())))
    store = SettingsStore(settings, None)
    clock = ManualClock(START_UTC)
    model = _model(config, clock, initialized=False)
    with EmulatorServer(model, host="127.0.0.1", port=0, baud=0) as emulator:
        link = Link(f"socket://127.0.0.1:{emulator.port}", baud=9600, timeout=2.0)
        keeper = TimeKeeper(clock.now, clock.seconds, watch=HostClockWatch(), policy=lambda: "host")
        mount = Mount(link, lambda: (store.settings.site.latitude, store.settings.site.longitude),
                      clock=clock.now, monotonic=clock.seconds, time_keeper=keeper)
        telescope = Telescope(mount, store, 0, registry=ClientRegistry(), interlock=Interlock())
        bridge = ZwoPortBridge(telescope, "127.0.0.1", 0).start()
        wire = Wire(bridge.port, f"{model.firmware.model}#".encode())
        try:
            wire.ask(["GVP"])  # the first command connects the Telescope
            _wait(lambda: mount.state.initialised and mount.state.status is not None, "the mount to be polled")

            def settle() -> None:
                """A poll after the command, so every snapshot reading is the mount's present."""
                for _ in range(50):
                    if mount.poll_once() is not None and mount.state.status_time is not None:
                        break

            _run(capture, segment, steps, wire, None, settle, lambda: int(bridge.status()["refusals"]))
        finally:
            wire.close()
            bridge.stop()
            telescope.shutdown()
            link.close()


def capture_all(which: str) -> dict[str, list[dict[str, Any]]]:
    if which == "emulator":
        return {name: capture_emulator(name).rows for name in EMULATOR_CONFIGS}
    return {name: capture_port(name).rows for name in PORT_CONFIGS}


def write(path: Path, captures: dict[str, list[dict[str, Any]]]) -> None:
    """One row a line, so a difference shows as the lines of the commands that answer differently."""
    lines = ["{"]
    for number, (name, rows) in enumerate(captures.items()):
        lines.append(f"{json.dumps(name)}: [")
        lines += [json.dumps(row, ensure_ascii=True) + ("," if i < len(rows) - 1 else "") for i, row in enumerate(rows)]
        lines.append("]" + ("," if number < len(captures) - 1 else ""))
    lines.append("}")
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


def read(path: Path) -> dict[str, list[dict[str, Any]]]:
    data: dict[str, list[dict[str, Any]]] = json.loads(path.read_text(encoding="ascii"))
    return data


if __name__ == "__main__":
    targets = sys.argv[1:] or ["emulator", "port"]
    for target in targets:
        out = EMULATOR_FILE if target == "emulator" else PORT_FILE
        write(out, capture_all(target))
        print(f"wrote {out}")
