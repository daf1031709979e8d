"""The ``alpaca-zwo`` command: start the server (on the built-in emulator unless --device is given)."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from pathlib import Path

from . import __version__
from ._exceptions import AlpacaZwoError, ConfigError
from .config import default_config_path, load_settings
from .server import AlpacaZwoServer, Overrides
from .store import SettingsStore

log = logging.getLogger("alpaca_zwo")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="alpaca-zwo",
        description="ASCOM Alpaca server for ZWO AM3/AM5/AM7 mounts. Without --device it drives the built-in "
        "mount emulator, so you can try it with no hardware.",
    )
    parser.add_argument("--device", metavar="URL",
                        help="the mount: a serial port (/dev/ttyACM0, COM3) or a pyserial URL such as "
                             "socket://192.168.4.1:4030 (the mount's WiFi); default: the built-in emulator")
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


def server_main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    path = args.config or default_config_path()
    try:
        settings = load_settings(path)
    except ConfigError as exc:
        print(f"alpaca-zwo: configuration error: {exc}", file=sys.stderr)
        return 2
    _configure_logging(args.log_level or settings.logging.level, settings.logging.file)
    overrides = Overrides(host=args.host, port=args.port, discovery_port=args.discovery_port,
                          device_url=args.device, mdns=args.mdns, emulator_speed=args.emulator_speed,
                          emulator_baud=args.emulator_baud, stellarium_port=args.stellarium_port,
                          zwo_port=args.zwo_port)
    from .setup import setup_routes

    server = AlpacaZwoServer(SettingsStore(settings, path), overrides, extra_routes_factory=setup_routes)
    stop = threading.Event()

    def on_signal(signum: int, _frame: object) -> None:
        log.info("signal %d: stopping", signum)
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        server.start()
    except (AlpacaZwoError, OSError) as exc:
        print(f"alpaca-zwo: cannot start: {exc}", file=sys.stderr)
        server.stop()
        return 1
    print(f"alpaca-zwo {__version__} serving (config: {path})", flush=True)
    for line in server.urls():
        print("  " + line, flush=True)
    try:
        stop.wait()
    finally:
        server.stop()
    print("alpaca-zwo stopped", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(server_main())
