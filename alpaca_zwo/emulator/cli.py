"""``alpaca-zwo-emulator``: run an emulated ZWO AM mount on TCP (and a pty) until stopped.

The first lines on stdout say where it listens, one per endpoint, so a script that passed
``--port 0`` can read the port back::

    tcp 127.0.0.1:40123
    pty /dev/pts/7
    control 127.0.0.1:40124
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from collections.abc import Sequence
from datetime import datetime, timezone
from types import FrameType

from ..zwo.firmware import (
    ACK_WHILE_SLEWING,
    DEFAULT_PRESET,
    GH_REPLIES,
    GPS_REPLIES,
    GT_MAPPINGS,
    HOME_FLAGS,
    HOME_READINGS,
    HP_WHILE_TRACKING,
    JOG_RATES,
    MODELS,
    NS_MOVES,
    PARK_REFUSALS,
    PIER_LETTERS,
    PRESETS,
    STATUS_WORDS,
    UNKNOWN_QUERIES,
    FirmwareVariant,
    preset,
)
from ..zwo.wire_values import MountMode
from .clock import ScaledClock
from .control import ControlServer
from .imperfection import ALTAZ_TERMS, EQUATORIAL_TERMS, MAX_NOISE_ARCSEC, Imperfection, parse_terms
from .model import FACTORY_LATITUDE, FACTORY_LONGITUDE, MountModel
from .server import EmulatorServer, pty_support_error

__all__ = ["build_parser", "main"]


def _iso_utc(text: str) -> datetime:
    try:
        value = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"not an ISO 8601 time: {text!r}") from exc
    return value.replace(tzinfo=timezone.utc) if value.tzinfo is None else value.astimezone(timezone.utc)


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0.0:
        raise argparse.ArgumentTypeError("must be > 0")
    return value


def _terms(text: str) -> str:
    """``--pointing-errors``: checked here so a typo is a usage error, not a perfect mount."""
    try:
        parse_terms(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc
    return text


def _noise(text: str) -> float:
    value = float(text)
    if not 0.0 <= value <= MAX_NOISE_ARCSEC:
        raise argparse.ArgumentTypeError(f"must be between 0 and {MAX_NOISE_ARCSEC:g} arcseconds")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="alpaca-zwo-emulator",
        description="Emulate a ZWO AM3/AM5/AM5N/AM7 mount on TCP (like its WiFi port) and a pty (like USB).",
    )
    net = parser.add_argument_group("endpoints")
    net.add_argument("--host", default="127.0.0.1", help="TCP address to listen on (default 127.0.0.1)")
    net.add_argument("--port", type=int, default=4030, help="TCP port (default 4030; 0 picks a free one)")
    net.add_argument("--pty", action="store_true", help="also serve a pseudo-terminal and print its path")
    net.add_argument("--pty-link", metavar="PATH", help="keep a symlink at PATH pointing at the current pty")
    net.add_argument("--baud", type=int, default=9600, help="line rate to pace bytes at (default 9600; 0 = unpaced)")
    net.add_argument(
        "--control-port",
        type=int,
        metavar="N",
        help="loopback control channel for faults and inspection (0 picks a free port)",
    )

    sky = parser.add_argument_group("emulated universe")
    sky.add_argument("--speed", type=_positive, default=1.0, help="run the clock F times faster than real time")
    sky.add_argument("--start-time", type=_iso_utc, metavar="ISO8601", help="true UTC at start (default now)")
    sky.add_argument(
        "--latitude",
        type=float,
        default=FACTORY_LATITUDE,
        help="site stored in the mount, degrees north (default: the factory Suzhou site)",
    )
    sky.add_argument(
        "--longitude",
        type=float,
        default=FACTORY_LONGITUDE,
        help="site stored in the mount, degrees EAST positive (default: the factory site)",
    )
    sky.add_argument(
        "--initialized", action="store_true", help="start as if a client had already set date, time (UTC) and site"
    )
    sky.add_argument(
        "--mode", choices=("eq", "altaz"), default="eq",
        help="mount mode in flash at start: eq, or altaz (as if :AA# had been sent and the mount restarted)",
    )

    errors = parser.add_argument_group("mechanical errors (alpaca_zwo/emulator/README.md, docs/pointing-errors.md)")
    errors.add_argument(
        "--pointing-errors", type=_terms, default="", metavar="TERMS",
        help="TPOINT terms in arcminutes, like IH=20,ID=-8,MA=12,ME=-9,CH=5,NP=2,TF=1.5 "
             f"(equatorial: {', '.join(EQUATORIAL_TERMS)}; alt-az: {', '.join(ALTAZ_TERMS)})")
    errors.add_argument("--pointing-noise", type=_noise, default=0.0, metavar="ARCSEC",
                        help="unmodelled scatter of every pointing, RMS arcseconds on the sky (repeatable)")
    errors.add_argument("--pointing-seed", type=int, default=0, metavar="N", help="the scatter's seed (default 0)")

    fw = parser.add_argument_group("firmware variant (a preset; the options below override its switches)")
    fw.add_argument("--preset", choices=tuple(PRESETS), default=DEFAULT_PRESET,
                    help="; ".join(f"{v.name}: {v.description}" for v in PRESETS.values()))
    fw.add_argument("--model", choices=MODELS, help="model reported by :GVP# (default: the preset's)")
    fw.add_argument("--firmware", metavar="X.Y.Z", help="version reported by :GV# (default: the preset's)")
    fw.add_argument("--home-flag", choices=HOME_FLAGS, help="when :GU# shows H")
    fw.add_argument("--gt-mapping", choices=GT_MAPPINGS,
                    help=":GT# digits: english 1=solar 2=lunar, chinese 1=lunar 2=solar")
    fw.add_argument("--gps-reply", choices=GPS_REPLIES, help=":Gps# answers 0/1/2 or an empty #")
    fw.add_argument("--hp-reply", choices=("none", "1#"), help=":hP# answers nothing or 1#/0#")
    fw.add_argument("--gh-reply", choices=GH_REPLIES, help=":Gh# answers #, 0#, or 1#/0# by whether a home completed")
    fw.add_argument("--pier-letter", choices=PIER_LETTERS,
                    help=":Gm# names the pointing state, the axes' state as in the north, or the hour angle's side")
    fw.add_argument("--ns-moves", choices=NS_MOVES,
                    help=":Mn#/:Mgn move toward the sky's north, or one way of the Dec axis")
    for flag, choices, text in (
            ("--park-refusal", PARK_REFUSALS, "a parked mount refuses motion as documented, or with e14# (1.8.8)"),
            ("--hp-while-tracking", HP_WHILE_TRACKING, ":hP# parks while tracking, or is ignored (1.8.8)"),
            ("--status-word", STATUS_WORDS, ":GU# as documented, or the 1.8.8 word (M, state digit)"),
            ("--unknown-query", UNKNOWN_QUERIES, "an unknown :G..# is silent, or answers # (1.8.8)"),
            ("--home-reading", HOME_READINGS, "home reads N and HA -6 h, or E and +6 h (1.8.8)"),
            ("--jog-rates", JOG_RATES, ":R1#-:R7# as documented, or as measured on an AM5N"),
            ("--ack-while-slewing", ACK_WHILE_SLEWING, ":Te#/:Td# during a slew answered at once, once it "
                                                        "ends (1.8.8), or never")):
        fw.add_argument(flag, choices=choices, help=text)
    for flag, text in (("--compound-goto-sync", ":SMeq/:SMMC work as documented (real firmware answers e2#)"),
                       ("--custom-tracking", ":STRnn# custom rate works (real: no reply)"),
                       ("--gmza-south-azimuth", ":GMZA# azimuth measured from south"),
                       ("--goto-flip-at-meridian", "a GOTO flips at the meridian, not past the track-past limit"),
                       ("--site-in-flash", "a site set by :St/:Sg is kept across a power cycle"),
                       ("--park-at-home", ":hP# goes home, not to the factory park")):
        fw.add_argument(flag, action="store_const", const=True, help=text)

    parser.add_argument("--log-level", default="WARNING", help="DEBUG, INFO, WARNING (default) or ERROR")
    return parser


def firmware_from_args(args: argparse.Namespace) -> FirmwareVariant:
    """The chosen preset with the switches given on the command line changed."""
    switches = {name: getattr(args, name) for name in (
        "model", "home_flag", "gt_mapping", "gps_reply", "gh_reply", "compound_goto_sync", "custom_tracking",
        "gmza_south_azimuth", "goto_flip_at_meridian", "pier_letter", "ns_moves", "site_in_flash", "park_refusal",
        "hp_while_tracking", "status_word", "unknown_query", "home_reading", "jog_rates", "park_at_home",
        "ack_while_slewing")}
    switches["version"] = args.firmware
    overrides = {name: value for name, value in switches.items() if value is not None}
    if args.hp_reply is not None:  # "none" is a value of its own: the :hP# that answers nothing
        overrides["hp_reply"] = None if args.hp_reply == "none" else args.hp_reply
    return preset(args.preset, **overrides)


def _stop_on_signals() -> threading.Event:
    """SIGTERM where the OS has it, Ctrl-C everywhere, Ctrl-Break (SIGBREAK) on Windows: set the event."""
    stop = threading.Event()

    def _on_signal(_signum: int, _frame: FrameType | None) -> None:
        stop.set()

    for name in ("SIGTERM", "SIGINT", "SIGBREAK"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), _on_signal)
    return stop


def _start_control(server: EmulatorServer, port: int | None) -> ControlServer | None:
    """The control channel when asked for; OSError when its port cannot be opened."""
    return ControlServer(server, port=port).start() if port is not None else None


def _announce(args: argparse.Namespace, firmware: FirmwareVariant, clock: ScaledClock, server: EmulatorServer,
              control: ControlServer | None) -> None:
    """The endpoint lines a supervisor (or a test) reads, flushed at once."""
    print(
        f"alpaca-zwo-emulator: {firmware.describe()}, baud {server.baud}, "
        f"speed {clock.speed:g}x, start {clock.now().isoformat(timespec='seconds')}"
    )
    print(f"tcp {args.host}:{server.port}")
    if server.pty_path:
        print(f"pty {server.pty_path}")
    if control is not None:
        print(f"control 127.0.0.1:{control.port}")
    sys.stdout.flush()


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    firmware = firmware_from_args(args)
    # Handlers first: a supervisor may send SIGTERM as soon as it has read the endpoint lines.
    stop = _stop_on_signals()
    if args.pty and (reason := pty_support_error()):
        print(f"alpaca-zwo-emulator: {reason}", file=sys.stderr)
        return 2

    clock = ScaledClock(speed=args.speed, start_utc=args.start_time)
    mode = MountMode.ALTAZ if args.mode == "altaz" else MountMode.EQUATORIAL
    imperfection = Imperfection.of(args.pointing_errors, args.pointing_noise, args.pointing_seed)
    model = MountModel(clock, firmware, site=(args.latitude, args.longitude), initialized=args.initialized, mode=mode,
                       imperfection=imperfection)
    server = EmulatorServer(model, host=args.host, port=args.port, baud=args.baud, pty=args.pty, pty_link=args.pty_link)
    try:
        server.start()
    except OSError as exc:
        print(f"alpaca-zwo-emulator: cannot listen on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 2
    try:
        control = _start_control(server, args.control_port)
    except OSError as exc:
        print(f"alpaca-zwo-emulator: cannot open control port {args.control_port}: {exc}", file=sys.stderr)
        server.stop()
        return 2
    _announce(args, firmware, clock, server, control)
    try:
        while not stop.wait(0.5):
            pass
    finally:
        if control is not None:
            control.stop()
        server.stop()
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
