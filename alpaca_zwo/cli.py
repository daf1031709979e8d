"""The ``alpaca-zwo`` command: start the server (on the built-in emulator unless --device is given)."""

from __future__ import annotations

import argparse
import errno
import logging
import signal
import sys
import threading
from pathlib import Path

from . import __version__
from ._exceptions import AlpacaZwoError, ConfigError
from .alpaca.listen_check import host_problem, listen_problem, port_in_use
from .config.file import default_config_path, load_settings, remove_stale_temp_files
from .config.settings import Settings
from .config.store import SettingsStore
from .server import AlpacaZwoServer, EmbeddedEmulator, Overrides
from .service import KINDS, render
from .zwo.devices import DeviceError, check_device, find_mount, format_candidates, list_candidates
from .zwo.firmware import PRESETS
from .zwo.link import Link
from .zwo.survey import SurveyContext, SurveyReport, run_survey

log = logging.getLogger("alpaca_zwo")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="alpaca-zwo",
        description="ASCOM Alpaca server for ZWO AM3/AM5/AM7 mounts. Without --device it drives the built-in "
        "mount emulator, so you can try it with no hardware.",
    )
    parser.add_argument("--device", metavar="URL",
                        help="the mount: a serial port (/dev/ttyACM0, COM3), a pyserial URL such as "
                             "socket://192.168.4.1:4030 (the mount's WiFi), or 'auto' to find the mount on USB; "
                             "default: the built-in emulator")
    parser.add_argument("--list-devices", action="store_true",
                        help="list the serial ports, what each is and what answered, then exit")
    parser.add_argument("--probe", action="append", default=[], metavar="PORT",
                        help="also ask PORT (one the OS does not list, e.g. a symlink) with --device auto / "
                             "--list-devices; may be repeated")
    parser.add_argument("--print-service", choices=KINDS, metavar="KIND",
                        help="print a start-at-boot definition for this install and these options, then exit: "
                             "systemd (unit), launchd (plist) or windows (PowerShell for Task Scheduler)")
    parser.add_argument("--host", help="address to listen on (default from the config file: 0.0.0.0)")
    parser.add_argument("--port", type=int, help="HTTP port (default 11111; 0 picks a free port)")
    parser.add_argument("--discovery-port", type=int, help="Alpaca UDP discovery port (default 32227; 0 = off)")
    parser.add_argument("--config", type=Path, metavar="FILE",
                        help=f"TOML configuration file (default {default_config_path()})")
    parser.add_argument("--mdns", action="store_true", default=None,
                        help="advertise the setup page with mDNS/zeroconf (multicasts on your network; off by default)")
    parser.add_argument("--emulator-speed", type=float, metavar="F",
                        help="run the built-in emulator's clock F times faster")
    parser.add_argument("--emulator-baud", type=int, metavar="N",
                        help="pace the built-in emulator like an N-baud line (0 = unpaced)")
    parser.add_argument("--emulator-mode", choices=("eq", "altaz"),
                        help="start the built-in emulator in equatorial or alt-az mode (default from the config "
                             "file: eq)")
    parser.add_argument("--emulator-preset", choices=tuple(PRESETS), metavar="NAME",
                        help="the built-in emulator's firmware: one of " + ", ".join(PRESETS)
                             + " (default from the config file's [emulator] preset)")
    parser.add_argument("--survey", action="store_true",
                        help="ask the mount (--device, or the built-in emulator) only questions that move and "
                             "change nothing, write every exchange with its timing to a report file, say which "
                             "firmware variants its answers settle, then exit (docs/survey.md)")
    parser.add_argument("--survey-out", type=Path, metavar="FILE",
                        help="where --survey writes its report (default: alpaca-zwo-survey-<UTC time>.txt in the "
                             "current directory)")
    parser.add_argument("--zwo-port", type=int, metavar="N",
                        help="serve the mount's own ZWO protocol on TCP port N for INDI and other ZWO/LX200 "
                             "drivers (like the mount's WiFi port 4030), shared with Alpaca; for this run only")
    parser.add_argument("--stellarium-port", type=int, metavar="N",
                        help="serve Stellarium's telescope protocol on TCP port N (its default is 10001), "
                             "for this run only; see [stellarium] in the config")
    parser.add_argument("--log-level", default=None, choices=["DEBUG", "INFO", "WARNING", "ERROR"],
                        help="logging level (default from the config file: INFO)")
    parser.add_argument("--version", action="version", version=f"alpaca-zwo {__version__}")
    return parser


def _configure_logging(level: str, file: str) -> None:
    handlers: list[logging.Handler] = [logging.StreamHandler()]
    if file:
        from logging.handlers import RotatingFileHandler

        handlers = [RotatingFileHandler(file, maxBytes=5_000_000, backupCount=3), logging.StreamHandler()]
    logging.basicConfig(level=getattr(logging, level), handlers=handlers,
                        format="%(asctime)s %(levelname)-7s %(name)s: %(message)s")


def _service_args(argv: list[str], config: Path) -> list[str]:
    """This command line as the service should run it: without --print-service, with an absolute --config.

    Everything else is passed through as given, so options added later reach the service too.
    """
    out: list[str] = []
    words = iter(argv)
    for word in words:
        if word in ("--print-service", "--config"):
            next(words, None)  # and its value
        elif not word.startswith(("--print-service=", "--config=")):
            out.append(word)
    return ["--config", str(config.absolute()), *out]


def _resolve_device(args: argparse.Namespace) -> str | None:
    """``--device auto`` becomes the mount's port; an explicit port is checked. DeviceError says what to do."""
    device: str | None = args.device
    if device == "auto":
        device = find_mount(args.probe)
        print(f"alpaca-zwo: found the mount at {device}", file=sys.stderr, flush=True)
        return device
    if device:
        warning = check_device(device)
        if warning:
            print(f"alpaca-zwo: warning: {warning}", file=sys.stderr, flush=True)
    return device


def _one_shot(args: argparse.Namespace, argv: list[str], path: Path) -> int | None:
    """The commands that print something and exit (None when the server should run)."""
    if args.print_service:
        print(render(args.print_service, _service_args(argv, path)), end="")
        return 0
    if args.list_devices:
        candidates = list_candidates(args.probe)
        print(format_candidates(candidates))
        mounts = [c.device for c in candidates if c.is_mount]
        print(f"mount: {', '.join(mounts)}" if mounts else "no ZWO mount answered")
        return 0
    return None


def _install_stop_handlers(stop: threading.Event) -> None:
    """SIGTERM where the OS has it, Ctrl-C everywhere, Ctrl-Break (SIGBREAK) on Windows."""

    def on_signal(signum: int, _frame: object) -> None:
        log.info("signal %d: stopping", signum)
        stop.set()

    for name in ("SIGINT", "SIGTERM", "SIGBREAK"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), on_signal)


def _port_taken(port: int, where: str) -> str:
    """The port is held by another listener: most often this same server started twice, so say how to
    reach that one, and how to start this one elsewhere."""
    other = 11112 if port == 11111 else 11111
    return (f"server.port {port} is in use (set by {where}): is alpaca-zwo already running? "
            f"open http://127.0.0.1:{port}/setup; or start on another port with --port {other}")


def _where(args: argparse.Namespace, path: Path) -> str:
    """Where the listening address was set: on the command line or in the config file."""
    return "--host/--port" if args.host is not None or args.port is not None else f"[server] in {path}"


def _listen_problem(args: argparse.Namespace, settings: Settings, path: Path) -> str | None:
    """One line saying why the HTTP server could not listen where it is told to, and where that is set."""
    host = args.host if args.host is not None else settings.server.host
    port = args.port if args.port is not None else settings.server.port
    problem = listen_problem(host, port)
    if problem is None:
        return None
    where = _where(args, path)
    if host_problem(host) is None and port_in_use(host, port):
        return _port_taken(port, where)
    return f"{problem} (set by {where})"


def _clean_temp_files(path: Path) -> None:
    """Temporary files a killed save left beside the settings file (after logging is set up, to say so)."""
    removed = remove_stale_temp_files(path)
    if removed:
        log.info("removed %d stale temporary settings file(s) in %s", len(removed), path.parent)


def _survey_report(args: argparse.Namespace, settings: Settings) -> SurveyReport:
    """The survey on the first device (or the built-in emulator), before any server touches the mount:
    nothing else is on the line, so the recorded timing is the mount's own."""
    device = settings.devices[0]
    url = args.device or device.url
    emulator = None
    if not url:
        baud = settings.emulator.baud if args.emulator_baud is None else args.emulator_baud
        emulator = EmbeddedEmulator(settings, 1.0, baud, args.emulator_mode, args.emulator_preset)
    link = Link(emulator.url if emulator else url, baud=device.baud, timeout=device.timeout)
    try:
        link.open()
        preset_name = emulator.model.firmware.name if emulator else ""
        return run_survey(link.exchange, SurveyContext.here(__version__, url, preset_name))
    finally:
        link.close()
        if emulator is not None:
            emulator.stop()


def _survey(args: argparse.Namespace, settings: Settings) -> int:
    """``--survey``: run it, write the report, print the verdict and where the file is."""
    try:
        report = _survey_report(args, settings)
    except AlpacaZwoError as exc:
        print(f"alpaca-zwo: survey failed: {exc}", file=sys.stderr)
        return 1
    out: Path = args.survey_out or Path(report.file_name())
    try:
        out.write_text(report.text(), encoding="utf-8")
    except OSError as exc:
        print(report.text(), end="")
        print(f"alpaca-zwo: could not write the survey report to {out}: {exc}", file=sys.stderr)
        return 1
    print(f"mount: {report.identity()}")
    for verdict in report.verdicts():
        print("  " + verdict.line())
    if report.stopped:
        print(f"survey stopped early: {report.stopped}")
    print(f"survey report written to {out.absolute()}", flush=True)
    return 1 if report.stopped else 0


def server_main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    path = args.config or default_config_path()
    done = _one_shot(args, sys.argv[1:] if argv is None else argv, path)
    if done is not None:
        return done
    try:
        args.device = _resolve_device(args)
    except DeviceError as exc:
        print(f"alpaca-zwo: {exc}", file=sys.stderr)
        return 1
    try:
        settings = load_settings(path)
    except ConfigError as exc:
        print(f"alpaca-zwo: configuration error: {exc}", file=sys.stderr)
        return 2
    _configure_logging(args.log_level or settings.logging.level, settings.logging.file)
    if args.survey:
        return _survey(args, settings)
    _clean_temp_files(path)
    overrides = Overrides(host=args.host, port=args.port, discovery_port=args.discovery_port,
                          device_url=args.device, mdns=args.mdns, emulator_speed=args.emulator_speed,
                          emulator_baud=args.emulator_baud, emulator_mode=args.emulator_mode,
                          emulator_preset=args.emulator_preset,
                          stellarium_port=args.stellarium_port,
                          zwo_port=args.zwo_port)
    from .web import setup_routes

    problem = _listen_problem(args, settings, path)
    if problem is not None:
        print(f"alpaca-zwo: cannot start: {problem}", file=sys.stderr)
        return 1
    server = AlpacaZwoServer(SettingsStore(settings, path), overrides, extra_routes_factory=setup_routes)
    stop = threading.Event()
    _install_stop_handlers(stop)
    try:
        server.start()
    except (AlpacaZwoError, OSError, ValueError) as exc:  # waitress: ValueError for a host it cannot use
        taken = isinstance(exc, OSError) and exc.errno == errno.EADDRINUSE  # taken since the check above
        port = server.settings.server.port if args.port is None else args.port
        reason = _port_taken(port, _where(args, path)) if taken else exc
        print(f"alpaca-zwo: cannot start: {reason}", file=sys.stderr)
        server.stop()
        return 1
    print(f"alpaca-zwo {__version__} serving (config: {path})", flush=True)
    for line in server.urls():
        print("  " + line, flush=True)
    try:
        while not stop.wait(0.5):  # a timed wait: Windows delivers Ctrl-C only between waits
            pass
    finally:
        server.stop()
    print("alpaca-zwo stopped", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(server_main())
