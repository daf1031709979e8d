"""Track a synthetic comet with RightAscensionRate/DeclinationRate and measure the pointing error.

The server runs on its built-in emulator (in process, so the emulator's own truth can be read). For
each rate pair the mount slews to a start point, the offsets are set, and for ``--minutes`` of mount
time the emulator's reported position is sampled against the ephemeris (start + rate x elapsed).
Guide pulses run at the default 0.5x guide rate. Prints RMS and max error per case and overall.
``--mode altaz`` starts the emulated mount in alt-az mode, where the pulses are timed moves.

    python -m benchmarks.comet              # 10 minutes per case at 5x (about 9 minutes in all)
    python -m benchmarks.comet --minutes 2  # quicker
    python -m benchmarks.comet --mode altaz
"""

from __future__ import annotations

import argparse
import math
import statistics
import tempfile
import time
from pathlib import Path

import requests

from alpaca_zwo.config.settings import EmulatorSettings, ServerSettings, Settings, SiteSettings, assign_unique_ids
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.server import AlpacaZwoServer

SIDEREAL_PER_SI = 1.00273790935
#: (RA arcsec/s, Dec arcsec/s): slow and fast comets, both signs.
CASES = [(0.5, 0.5), (2.0, -1.5), (-3.5, 2.5), (5.0, -5.0)]


class Client:
    def __init__(self, port: int) -> None:
        self.base = f"http://127.0.0.1:{port}/api/v1/telescope/0/"
        self.session = requests.Session()

    def get(self, member: str) -> object:
        body = self.session.get(self.base + member, params={"ClientID": 7}, timeout=10).json()
        assert body["ErrorNumber"] == 0, body
        return body["Value"]

    def put(self, member: str, **fields: object) -> None:
        body = self.session.put(self.base + member, data={"ClientID": 7, **fields}, timeout=30).json()
        assert body["ErrorNumber"] == 0, body


def run_case(server: AlpacaZwoServer, client: Client, ra_arcsec_s: float, dec_arcsec_s: float,
             minutes: float) -> list[float]:
    emulator = server.emulators[0]
    assert emulator is not None
    model, clock = emulator.model, emulator.clock
    client.put("rightascensionrate", RightAscensionRate=0.0)
    client.put("declinationrate", DeclinationRate=0.0)
    lst = float(client.get("siderealtime"))  # type: ignore[arg-type]
    client.put("slewtocoordinatesasync", RightAscension=(lst + 1.0) % 24.0, Declination=20.0)
    while client.get("slewing"):
        time.sleep(0.05)
    client.put("rightascensionrate", RightAscensionRate=ra_arcsec_s / 15.0 / SIDEREAL_PER_SI)
    client.put("declinationrate", DeclinationRate=dec_arcsec_s)
    ra0, dec0 = model.position()
    t0 = clock.seconds()
    errors = []
    while clock.seconds() - t0 < minutes * 60.0:
        time.sleep(0.02)
        ra, dec = model.position()
        elapsed = clock.seconds() - t0
        want_ra = ra0 + ra_arcsec_s * elapsed / 3600.0 / 15.0
        want_dec = dec0 + dec_arcsec_s * elapsed / 3600.0
        d_ra = ((ra - want_ra + 12.0) % 24.0 - 12.0) * 15.0 * 3600.0 * math.cos(math.radians(dec))
        errors.append(math.hypot(d_ra, (dec - want_dec) * 3600.0))
    return errors


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.comet", description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="mount minutes per case (default 10)")
    parser.add_argument("--speed", type=float, default=5.0, help="emulator clock rate (default 5x)")
    parser.add_argument("--mode", choices=("eq", "altaz"), default="eq", help="the emulated mount's mode")
    args = parser.parse_args()
    settings = assign_unique_ids(Settings(
        server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0),
        site=SiteSettings(latitude=51.4769, longitude=-0.0005, elevation=46.0),
        emulator=EmulatorSettings(speed=args.speed, baud=9600, mode=args.mode),
    ))
    with tempfile.TemporaryDirectory() as tmp:
        server = AlpacaZwoServer(SettingsStore(settings, Path(tmp) / "config.toml"))
        server.start()
        try:
            client = Client(server.port)
            client.put("connected", Connected="True")
            client.put("tracking", Tracking="True")
            everything: list[float] = []
            print(f"emulator {args.speed:g}x at 9600 baud, {args.mode} mode, {args.minutes:g} mount minutes per case, "
                  "guide rate 0.5x")
            print(f"{'RA ″/s':>8} {'Dec ″/s':>8} {'samples':>8} {'RMS ″':>7} {'p95 ″':>7} {'max ″':>7}")
            for ra_rate, dec_rate in CASES:
                errors = run_case(server, client, ra_rate, dec_rate, args.minutes)
                everything += errors
                rms = math.sqrt(statistics.fmean(e * e for e in errors))
                p95 = sorted(errors)[int(0.95 * (len(errors) - 1))]
                print(f"{ra_rate:8.1f} {dec_rate:8.1f} {len(errors):8d} {rms:7.2f} {p95:7.2f} {max(errors):7.2f}")
            rms = math.sqrt(statistics.fmean(e * e for e in everything))
            print(f"overall: RMS {rms:.2f}″, max {max(everything):.2f}″ over {len(everything)} samples")
        finally:
            server.stop()


if __name__ == "__main__":
    main()
