"""Landing accuracy of Alt/Az and coordinate slews (issue 13): ``python -m benchmarks.motion``.

The server runs in this process with its built-in emulator (paced at 9600 baud, at ``--speed``
times real time), exactly as ``tests/motion/test_motion.py`` measures it: the truth is the emulator's
own ``MountModel.horizontal()`` / ``.position()`` read the moment the server's ``Slewing`` (polled
over HTTP every few milliseconds) turns false, i.e. when a client would start its exposure.

The targets are seeded: Alt/Az slews cycle through every combination of tracking on/off, east/west
of the meridian and short hops/long slews; coordinate slews alternate tracking on/off and east/west
hour angles. Results: ``benchmarks/results/<stamp>-motion.json`` and ``.md``, and ``.log`` with the
motion supervisor's DEBUG log (its account of each landing).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import random
import shlex
import sys
import tempfile
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from .client import AlpacaClient, ReplyError
from .stats import percentile

RESULTS = Path(__file__).resolve().parent / "results"
LATITUDE = 51.4769
POLL_S = 0.003  # how often Slewing is read while a slew runs (real seconds)
SLEW_LIMIT_S = 240.0  # a slew that has not ended by then counts as failed (real seconds)


@dataclass(frozen=True)
class Case:
    """One slew: Alt/Az (alt, az degrees) or coordinates (HA hours, Dec degrees)."""

    kind: str  # "altaz" or "coord"
    a: float
    b: float
    tracking: bool
    side: str  # "east" / "west" of the meridian
    length: str  # "short" / "long" (Alt/Az); "-" for coordinate slews


def great_circle_arcsec(lon1: float, lat1: float, lon2: float, lat2: float) -> float:
    """Angle between two points given as (longitude-like, latitude-like) degrees."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    cos = math.sin(p1) * math.sin(p2) + math.cos(p1) * math.cos(p2) * math.cos(math.radians(lon1 - lon2))
    return math.degrees(math.acos(max(-1.0, min(1.0, cos)))) * 3600.0


#: One block of Alt/Az slews: every (side, length, tracking) combination once; each short hop follows
#: a long slew to the same side of the meridian, so it really is a hop of a few degrees.
BLOCK = (("east", "long", True), ("east", "short", False), ("east", "long", False), ("east", "short", True),
         ("west", "long", True), ("west", "short", False), ("west", "long", False), ("west", "short", True))


def altaz_cases(n: int, rng: random.Random) -> list[Case]:
    """``n`` Alt/Az targets, cycling through :data:`BLOCK`."""
    cases: list[Case] = []
    alt, az = 45.0, 120.0
    for index in range(n):
        side, length, tracking = BLOCK[index % len(BLOCK)]
        low, high = (20.0, 160.0) if side == "east" else (200.0, 340.0)
        if length == "short":
            # A hop of 2-12 degrees from the last target (settling on a nearby object).
            alt = min(80.0, max(20.0, alt + rng.uniform(-6.0, 6.0)))
            az = min(high, max(low, az + rng.choice((-1.0, 1.0)) * rng.uniform(2.0, 10.0)))
        else:
            alt, az = rng.uniform(20.0, 80.0), rng.uniform(low, high)
        cases.append(Case("altaz", round(alt, 4), round(az, 4), tracking, side, length))
    return cases


def explicit_cases(text: str) -> list[Case]:
    """``"ALT,AZ,on;ALT,AZ,off"``: Alt/Az slews given by hand, e.g. to replay an outlier."""
    cases = []
    for item in filter(None, text.split(";")):
        alt, az, tracking = item.split(",")
        side = "east" if float(az) < 180.0 else "west"
        cases.append(Case("altaz", float(alt), float(az), tracking.strip() == "on", side, "given"))
    return cases


def coord_cases(n: int, rng: random.Random) -> list[Case]:
    """``n`` coordinate targets by hour angle, all above 20° altitude at the site."""
    cases: list[Case] = []
    for index in range(n):
        tracking = index % 2 == 0
        side = "east" if (index // 2) % 2 == 0 else "west"
        while True:
            ha = rng.uniform(0.3, 5.0) * (-1.0 if side == "east" else 1.0)
            dec = rng.uniform(-10.0, 80.0)
            h, d, lat = math.radians(ha * 15.0), math.radians(dec), math.radians(LATITUDE)
            alt = math.degrees(math.asin(math.sin(d) * math.sin(lat) + math.cos(d) * math.cos(lat) * math.cos(h)))
            if alt > 20.0:
                break
        cases.append(Case("coord", round(ha, 5), round(dec, 4), tracking, side, "-"))
    return cases


class Bench:
    """The in-process server and the client that drives it."""

    def __init__(self, speed: float, baud: int, work: Path) -> None:
        from alpaca_zwo.config.settings import (
            EmulatorSettings,
            ServerSettings,
            Settings,
            SiteSettings,
            assign_unique_ids,
        )
        from alpaca_zwo.config.store import SettingsStore
        from alpaca_zwo.server import AlpacaZwoServer

        settings = assign_unique_ids(Settings(
            server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0),
            site=SiteSettings(latitude=LATITUDE, longitude=-0.0005, elevation=46.0),
            emulator=EmulatorSettings(speed=speed, baud=baud),
        ))
        self.server = AlpacaZwoServer(SettingsStore(settings, work / "config.toml"))
        self.server.start()
        emulator = self.server.emulators[0]
        assert emulator is not None
        self.model = emulator.model
        self.client = AlpacaClient("127.0.0.1", self.server.port, client_id=4711, timeout=60.0)
        self.client.put("connected", Connected="true")

    def close(self) -> None:
        self.client.close()
        self.server.stop()

    def wait_slew(self) -> float:
        """Real seconds until Slewing reads false (the client's "settled" moment)."""
        start = time.monotonic()
        while time.monotonic() - start < SLEW_LIMIT_S:
            if not self.client.get("slewing"):
                return time.monotonic() - start
            time.sleep(POLL_S)
        raise TimeoutError("the slew did not end")

    def run(self, case: Case) -> dict[str, Any]:
        if bool(self.client.get("tracking")) != case.tracking:
            self.client.put("tracking", Tracking=str(case.tracking).lower())
        before = self.model.horizontal()
        if case.kind == "altaz":
            self.client.put("slewtoaltazasync", Azimuth=case.b, Altitude=case.a)
            seconds = self.wait_slew()
            alt, az = self.model.horizontal()
            error = great_circle_arcsec(az, alt, case.b, case.a)
            served = great_circle_arcsec(float(self.client.get("azimuth")), float(self.client.get("altitude")),
                                         case.b, case.a)
            target = (case.a, case.b)
        else:
            lst = float(self.client.get("siderealtime"))
            ra = (lst - case.a) % 24.0
            self.client.put("slewtocoordinatesasync", RightAscension=round(ra, 7), Declination=case.b)
            seconds = self.wait_slew()
            got_ra, got_dec = self.model.position()
            error = great_circle_arcsec(got_ra * 15.0, got_dec, ra * 15.0, case.b)
            served = great_circle_arcsec(float(self.client.get("rightascension")) * 15.0,
                                         float(self.client.get("declination")), ra * 15.0, case.b)
            target = (ra, case.b)
        after = self.model.horizontal()
        slew_deg = great_circle_arcsec(before[1], before[0], after[1], after[0]) / 3600.0
        return {
            "kind": case.kind, "tracking": case.tracking, "side": case.side, "length": case.length,
            "target": target, "slew_deg": round(slew_deg, 2),
            "seconds": round(seconds, 2), "error_arcsec": round(error, 3), "served_error_arcsec": round(served, 3),
        }


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    errors = [r["error_arcsec"] for r in rows]
    return {"n": len(errors), "median": percentile(errors, 50), "p90": percentile(errors, 90),
            "max": max(errors) if errors else None,
            "over_1": sum(1 for e in errors if e >= 1.0), "over_5": sum(1 for e in errors if e >= 5.0)}


def groups(rows: list[dict[str, Any]]) -> list[tuple[str, dict[str, Any]]]:
    """Summaries of every subset the issue names, then the totals."""
    out: list[tuple[str, dict[str, Any]]] = []
    for kind, name in (("altaz", "Alt/Az"), ("coord", "coordinates")):
        mine = [r for r in rows if r["kind"] == kind and "error_arcsec" in r]
        if not mine:
            continue
        for tracking in (True, False):
            for side in ("east", "west"):
                sub = [r for r in mine if r["tracking"] is tracking and r["side"] == side]
                for length in sorted({r["length"] for r in sub}):
                    part = [r for r in sub if r["length"] == length]
                    label = f"{name}, tracking {'on' if tracking else 'off'}, {side}" + (
                        f", {length}" if length != "-" else "")
                    out.append((label, summary(part)))
        out.append((f"**{name}, all**", summary(mine)))
    return out


def render(results: dict[str, Any]) -> str:
    meta = results["meta"]
    lines = [f"### Landing accuracy {meta['started']}", "",
             f"- command: `{meta['command']}` ({meta['duration_s']} s)",
             f"- emulator speed {meta['speed']}x, {meta['baud']} baud, in-process; Slewing polled every "
             f"{POLL_S * 1000:.0f} ms; commit {meta['commit']}; load average at start "
             f"{' / '.join(f'{v:.2f}' for v in meta['loadavg_start'])}, at end "
             f"{' / '.join(f'{v:.2f}' for v in meta['loadavg_end'])}", "",
             "| Slews | n | median ″ | p90 ″ | max ″ | ≥ 1″ | ≥ 5″ |", "|---|---|---|---|---|---|---|"]
    for label, s in groups(results["rows"]):
        lines.append(f"| {label} | {s['n']} | {s['median']:.2f} | {s['p90']:.2f} | {s['max']:.2f} | "
                     f"{s['over_1']} | {s['over_5']} |")
    failed = [r for r in results["rows"] if "error_arcsec" not in r]
    if failed:
        lines += ["", f"Failed slews: {len(failed)}: " + "; ".join(r["failure"] for r in failed[:5])]
    served = [r["served_error_arcsec"] for r in results["rows"] if "served_error_arcsec" in r]
    if served:
        lines += ["", f"What the server reported right after (Altitude/Azimuth or RA/Dec GETs) against the "
                  f"request: median {percentile(served, 50):.2f}″, max {max(served):.2f}″."]
    slews = [r for r in results["rows"] if "seconds" in r]
    if slews:
        lines.append(f"Slews took {min(r['seconds'] for r in slews):.1f}-{max(r['seconds'] for r in slews):.1f} "
                     f"real s ({min(r['slew_deg'] for r in slews):.1f}-{max(r['slew_deg'] for r in slews):.1f}° "
                     f"on the sky).")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.motion", description=__doc__.splitlines()[0])
    parser.add_argument("--speed", type=float, default=2.0, help="emulator clock rate (default 2x real time)")
    parser.add_argument("--baud", type=int, default=9600, help="emulator line rate (default 9600)")
    parser.add_argument("--altaz", type=int, default=40, help="Alt/Az slews (default 40)")
    parser.add_argument("--coord", type=int, default=12, help="coordinate slews (default 12)")
    parser.add_argument("--seed", type=int, default=13)
    parser.add_argument("--targets", default="", metavar="ALT,AZ,on|off;...",
                        help="explicit Alt/Az slews instead of the seeded ones (to replay a case)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-motion"
    RESULTS.mkdir(parents=True, exist_ok=True)
    # The supervisor's own account of every landing (aim, t*, late arrivals, corrections), to explain outliers.
    handler = logging.FileHandler(RESULTS / f"{stamp}.log")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    motion_log = logging.getLogger("alpaca_zwo.motion")
    motion_log.setLevel(logging.DEBUG)
    motion_log.addHandler(handler)
    motion_log.propagate = False  # only into the file, not onto the console
    rng = random.Random(args.seed)
    cases = (explicit_cases(args.targets) if args.targets
             else altaz_cases(args.altaz, rng) + coord_cases(args.coord, rng))
    started = time.time()
    argv_used = sys.argv[1:] if argv is None else argv
    meta: dict[str, Any] = {"command": shlex.join(["python", "-m", "benchmarks.motion", *argv_used]),
                            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                            "speed": args.speed, "baud": args.baud, "seed": args.seed,
                            "loadavg_start": os.getloadavg(), "commit": _commit()}
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as work:
        bench = Bench(args.speed, args.baud, Path(work))
        try:
            for index, case in enumerate(cases):
                motion_log.debug("case %d: %s", index + 1, case)
                try:
                    row = bench.run(case)
                except (ReplyError, TimeoutError) as exc:
                    row = {"kind": case.kind, "tracking": case.tracking, "side": case.side, "length": case.length,
                           "failure": f"{case}: {exc}"}
                rows.append(row)
                print(f"[{time.strftime('%H:%M:%S')}] {index + 1}/{len(cases)} {row}", flush=True)
        finally:
            bench.close()
    meta.update(duration_s=round(time.time() - started, 1), loadavg_end=os.getloadavg())
    results = {"meta": meta, "rows": rows}
    (RESULTS / f"{stamp}.json").write_text(json.dumps(results, indent=1))
    table = render(results)
    (RESULTS / f"{stamp}.md").write_text(table)
    print(table)
    return 0 if all("error_arcsec" in r for r in rows) else 1


def _commit() -> str:
    import subprocess

    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10,
                              cwd=Path(__file__).resolve().parent).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


if __name__ == "__main__":
    sys.exit(main())
