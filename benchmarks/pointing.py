"""Blind GoTo error after 1, 3, 6, 9 and 12 syncs (issue 40 item 3): ``python -m benchmarks.pointing``.

The server runs in this process on its built-in emulator, made as imperfect as a real mount
(``[emulator] pointing_errors`` / ``pointing_noise``: docs/pointing-errors.md). For each error set:

1. **Syncs, as a plate solve makes them.** The client slews to a sync star; once ``Slewing`` is false
   the emulator's truth (its state's ``sky_ra_h``/``sky_dec_deg``: where the tube really points, what a
   plate solve would report) is sent as ``SyncToCoordinates``. Stars alternate sides of the meridian.
2. **Blind GoTos** over a grid of targets on both sides of the meridian; each miss is the angle between
   the target and the truth once ``Slewing`` is false. RMS and worst are measured after the 1st, 3rd,
   6th, 9th and 12th sync (the syncs accumulate; the grid is measured in between).

The harness relies on nothing but the Alpaca members a client uses (SlewToCoordinatesAsync, Slewing,
SyncToCoordinates) and the emulator's truth, so it measures a server with a pointing model exactly as
one without: without a model every count gives a single-sync figure (the last sync's offset applied
everywhere). Each error set gets a fresh server, configuration folder and emulator. Results:
``benchmarks/results/<stamp>-pointing.json`` and ``.md``.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from alpaca_zwo import sky

from .client import ReplyError
from .sync_residual import Bench, _commit, save

#: Error sets: name -> (TPOINT terms in arcminutes, scatter RMS in arcseconds).
ERROR_SETS: dict[str, tuple[str, float]] = {
    "realistic": ("IH=20,ID=-8,MA=12,ME=-9,CH=5,NP=2,TF=1.5", 5.0),
    "bad-polar": ("IH=20,ID=-8,MA=60,ME=-60,CH=5,NP=2,TF=1.5", 5.0),  # the polar axis about 1.4° off
    "perfect": ("", 0.0),  # the control: what the harness itself measures (landing, timing)
}
DEFAULT_SETS = ("realistic", "bad-polar")
COUNTS = (1, 3, 6, 9, 12)  # the goals: after 6 syncs RMS < 1′ and worst < 2′, after 9 RMS < 40″
#: Sync stars (HA hours, Dec toward the elevated pole), alternating sides; the first ones spread widest.
SYNC_STARS = [(-3.0, 25.0), (2.5, 55.0), (-1.5, 70.0), (3.5, 15.0), (-4.0, 50.0), (1.5, 35.0),
              (-2.5, 5.0), (4.5, 45.0), (-3.5, 75.0), (2.0, 10.0), (-1.5, 40.0), (3.0, 65.0)]
#: The grid of blind GoTo targets: both sides of the meridian, Dec toward the elevated pole.
GRID_HA = (-4.5, -3.0, -1.5, -0.5, 0.5, 1.5, 3.0, 4.5)
GRID_DEC = (0.0, 30.0, 60.0)
MIN_ALTITUDE = 20.0


def visible(latitude: float, points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The (HA, Dec) points, Dec mirrored toward the site's elevated pole, at least MIN_ALTITUDE high."""
    pole = 1.0 if latitude >= 0.0 else -1.0
    mirrored = [(ha, pole * dec) for ha, dec in points]
    return [(ha, dec) for ha, dec in mirrored if sky.equatorial_to_horizontal(ha, dec, latitude)[0] >= MIN_ALTITUDE]


class PointingBench:
    """One error set: the server on an imperfect emulator, its client, and the truth."""

    def __init__(self, bench: Bench) -> None:
        self.bench = bench

    def truth(self) -> tuple[float, float, str]:
        """(RA hours, Dec) the tube truly points at, in the mount's frame, and the pointing state."""
        state = self.bench.model.snapshot()
        return float(state["sky_ra_h"]), float(state["sky_dec_deg"]), str(state["side"])

    def goto(self, ha: float, dec: float) -> tuple[float, float]:
        """Slew to (HA, Dec) now, as a client would (RA from the server's sidereal time); the target's RA/Dec."""
        ra = (float(self.bench.client.get("siderealtime")) - ha) % 24.0
        self.bench.slew(ra, dec)
        return ra, dec

    def sync_on(self, ha: float, dec: float) -> dict[str, Any]:
        """Slew to a star, then sync on where the tube truly points (a plate solve): the miss before it, and
        the server's refusal if it refused the point (a pointing model may refuse one it finds grossly wrong)."""
        ra, dec = self.goto(ha, dec)
        sky_ra, sky_dec, _ = self.truth()
        miss = sky.angular_separation(ra, dec, sky_ra, sky_dec) * 3600.0
        row: dict[str, Any] = {"ha": ha, "dec": dec, "miss_before_arcsec": round(miss, 2)}
        try:
            self.bench.client.put("synctocoordinates", RightAscension=f"{sky_ra:.10f}", Declination=f"{sky_dec:.10f}")
        except ReplyError as exc:
            row["refused"] = str(exc)
            print(f"[{time.strftime('%H:%M:%S')}] sync at HA {ha:+.1f} h, Dec {dec:+.0f}° refused: {exc}", flush=True)
        return row

    def measure(self, grid: list[tuple[float, float]]) -> list[dict[str, Any]]:
        rows = []
        for ha, dec in grid:
            ra, dec = self.goto(ha, dec)
            sky_ra, sky_dec, side = self.truth()
            miss = sky.angular_separation(ra, dec, sky_ra, sky_dec) * 3600.0
            rows.append({"ha": ha, "dec": dec, "side": side, "miss_arcsec": round(miss, 2)})
        return rows


def run_set(name: str, args: argparse.Namespace) -> dict[str, Any]:
    terms, noise = ERROR_SETS[name]
    stars = visible(args.latitude, SYNC_STARS)
    grid = visible(args.latitude, [(ha, dec) for dec in GRID_DEC for ha in GRID_HA])
    result: dict[str, Any] = {"terms": terms, "noise_arcsec": noise, "syncs": [], "rounds": []}
    with tempfile.TemporaryDirectory() as work:
        bench = Bench(args.speed, args.baud, Path(work), latitude=args.latitude, pointing_errors=terms,
                      pointing_noise=noise, pointing_seed=args.seed)
        try:
            harness = PointingBench(bench)
            for count in COUNTS:
                while len(result["syncs"]) < min(count, len(stars)):
                    result["syncs"].append(harness.sync_on(*stars[len(result["syncs"])]))
                rows = harness.measure(grid)
                misses = [r["miss_arcsec"] for r in rows]
                summary = {"syncs": len(result["syncs"]), "refused": sum("refused" in r for r in result["syncs"]),
                           "n": len(rows), "rms_arcsec": round(rms(misses), 1),
                           "worst_arcsec": round(max(misses), 1), "rows": rows}
                result["rounds"].append(summary)
                print(f"[{time.strftime('%H:%M:%S')}] {name}: {summary['syncs']} syncs, RMS "
                      f"{summary['rms_arcsec']}″, worst {summary['worst_arcsec']}″", flush=True)
        finally:
            bench.close()
    return result


def rms(values: list[float]) -> float:
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else math.nan


def render(results: dict[str, Any]) -> str:
    meta = results["meta"]
    lines = [f"`{meta['command']}` on {meta['commit']}, {meta['started']}, {meta['duration_s']} s, latitude "
             f"{meta['latitude']}°, emulator {meta['speed']}x, seed {meta['seed']}", "",
             "| error set | syncs | targets | RMS | worst | RMS pierEast | RMS pierWest |",
             "|---|---|---|---|---|---|---|"]
    for name, result in results["sets"].items():
        for summary in result["rounds"]:
            sides = [rms([r["miss_arcsec"] for r in summary["rows"] if r["side"] == side]) for side in ("EAST", "WEST")]
            refused = f" ({summary['refused']} refused)" if summary.get("refused") else ""
            lines.append(f"| {name} | {summary['syncs']}{refused} | {summary['n']} | "
                         f"{summary['rms_arcsec'] / 60.0:.2f}′ | {summary['worst_arcsec'] / 60.0:.2f}′ | "
                         f"{sides[0] / 60.0:.2f}′ | {sides[1] / 60.0:.2f}′ |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.pointing", description=__doc__.splitlines()[0])
    parser.add_argument("--sets", default=",".join(DEFAULT_SETS),
                        help=f"error sets, of {', '.join(ERROR_SETS)} (default {','.join(DEFAULT_SETS)})")
    parser.add_argument("--latitude", type=float, default=52.5, help="site latitude (default 52.5; -33.87: Sydney)")
    parser.add_argument("--speed", type=float, default=20.0, help="emulator clock rate (default 20x real time)")
    parser.add_argument("--baud", type=int, default=0, help="emulator line rate (default 0: unpaced)")
    parser.add_argument("--seed", type=int, default=40, help="the scatter's seed (default 40)")
    args = parser.parse_args(argv)
    names = [name.strip() for name in args.sets.split(",") if name.strip()]
    unknown = [name for name in names if name not in ERROR_SETS]
    if unknown:
        parser.error(f"unknown error sets {unknown}; known: {', '.join(ERROR_SETS)}")
    argv_used = sys.argv[1:] if argv is None else argv
    meta: dict[str, Any] = {"command": shlex.join(["python", "-m", "benchmarks.pointing", *argv_used]),
                            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                            "latitude": args.latitude, "speed": args.speed, "baud": args.baud, "seed": args.seed,
                            "commit": _commit(), "loadavg_start": os.getloadavg()}
    started = time.time()
    results: dict[str, Any] = {"meta": meta, "sets": {name: run_set(name, args) for name in names}}
    meta.update(duration_s=round(time.time() - started, 1), loadavg_end=os.getloadavg())
    save(datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-pointing", results, render)
    return 0


if __name__ == "__main__":
    sys.exit(main())
