"""Where the mount really points after a sync and a re-slew (issue 24.1): ``python -m benchmarks.sync_residual``.

N.I.N.A.'s centring, repeated: the mount tracks near a target T; a plate solve says it points at S
(a few arcminutes off, with any fraction of a second of RA and of an arcsecond of Dec); the client
syncs to S and slews to T again. The mount takes S and T in whole seconds and arcseconds.

The truth is the emulator's: its mechanical pointing P (RA/Dec before its own alignment offset).
In the client's (synced) frame the mount points at P(now) + (S − P(at the sync)); the residual is
that minus T, in arcseconds on the sky, read when ``Slewing`` turns false. The server runs in this
process with its built-in emulator, as ``benchmarks/motion.py``. Results go to
``benchmarks/results/<stamp>-sync.json`` and ``.md``.

To measure another tree (the code before a change), run this file from a worktree of it:
``git worktree add /tmp/sync-before <commit> && cp benchmarks/sync_residual.py /tmp/sync-before/benchmarks/
&& cd /tmp/sync-before && python -m benchmarks.sync_residual``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import shlex
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from .client import AlpacaClient
from .stats import percentile

RESULTS = Path(__file__).resolve().parent / "results"
LATITUDE = 5.0  # near the equator: Dec +60 and -60 both rise well
DECLINATIONS = (0.2, 30.0, 60.0, -60.0)
POLL_S = 0.003


def wrap12(hours: float) -> float:
    return (hours + 12.0) % 24.0 - 12.0


class Bench:
    """The in-process server on its built-in emulator, and a client."""

    def __init__(self, speed: float, baud: int, work: Path, *, latitude: float = LATITUDE,
                 **emulator_settings: Any) -> None:
        """``emulator_settings``: further ``[emulator]`` settings (benchmarks/pointing.py: its pointing errors)."""
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
            site=SiteSettings(latitude=latitude, longitude=-0.0005, elevation=46.0),
            emulator=EmulatorSettings(speed=speed, baud=baud, **emulator_settings)))
        self.server = AlpacaZwoServer(SettingsStore(settings, work / "config.toml"))
        self.server.start()
        emulator = self.server.emulators[0]
        assert emulator is not None
        self.model = emulator.model
        self.client = AlpacaClient("127.0.0.1", self.server.port, client_id=2424, timeout=60.0)
        self.client.put("connected", Connected="true")
        self.client.put("tracking", Tracking="true")

    def close(self) -> None:
        self.client.close()
        self.server.stop()

    def mechanical(self) -> tuple[float, float]:
        state = self.model.snapshot()
        return (state["lst_h"] - state["raw_ha_h"]) % 24.0, state["raw_dec_deg"]

    def slew(self, ra: float, dec: float) -> None:
        self.client.put("slewtocoordinatesasync", RightAscension=f"{ra % 24.0:.10f}", Declination=f"{dec:.10f}")
        deadline = time.monotonic() + 120.0
        while self.client.get("slewing"):
            if time.monotonic() > deadline:
                raise TimeoutError("the slew did not end")
            time.sleep(POLL_S)

    def here(self) -> tuple[float, float]:
        return float(self.client.get("rightascension")), float(self.client.get("declination"))

    def centring(self, rng: random.Random) -> dict[str, Any]:
        here = self.here()
        solved = fraction_near(rng, here, 60.0)
        target = fraction_near(rng, here, 120.0)
        before = self.mechanical()
        self.client.put("synctocoordinates", RightAscension=f"{solved[0]:.10f}", Declination=f"{solved[1]:.10f}")
        self.slew(*target)
        after = self.mechanical()
        truth = (after[0] + wrap12(solved[0] - before[0]), after[1] + solved[1] - before[1])
        cos = math.cos(math.radians(target[1]))
        d_ra = wrap12(truth[0] - target[0]) * 54000.0 * cos
        d_dec = (truth[1] - target[1]) * 3600.0
        reported = self.here()
        served = math.hypot(wrap12(reported[0] - target[0]) * 54000.0 * cos, (reported[1] - target[1]) * 3600.0)
        return {"dec": round(target[1], 3), "ra_fraction_s": round(solved[0] * 3600.0 % 1.0, 3),
                "dec_fraction_arcsec": round(solved[1] * 3600.0 % 1.0, 3), "ra_arcsec": round(d_ra, 3),
                "dec_arcsec": round(d_dec, 3), "error_arcsec": round(math.hypot(d_ra, d_dec), 3),
                "served_error_arcsec": round(served, 3)}


def fraction_near(rng: random.Random, at: tuple[float, float], spread_arcsec: float) -> tuple[float, float]:
    """A position within ``spread_arcsec`` of ``at`` with random fractions of a second and an arcsecond."""
    ra_s = round(at[0] * 3600.0 + rng.uniform(-spread_arcsec, spread_arcsec) / 15.0) + rng.random()
    dec_as = round(at[1] * 3600.0 + rng.uniform(-spread_arcsec, spread_arcsec)) + rng.random()
    return (ra_s / 3600.0) % 24.0, dec_as / 3600.0


def render(results: dict[str, Any]) -> str:
    meta, rows = results["meta"], results["rows"]
    lines = [f"`{meta['command']}` on {meta['commit']}, {meta['started']}, {meta['duration_s']} s, "
             f"emulator {meta['speed']}x at {meta['baud']} baud, seed {meta['seed']}", "",
             "| Dec | n | median ″ | p90 ″ | max ″ | ≥ 1″ | reported, max ″ |", "|---|---|---|---|---|---|---|"]
    groups = [(f"{dec:+.1f}°", [r for r in rows if abs(r["dec"] - dec) < 1.0]) for dec in DECLINATIONS]
    for label, group in [*groups, ("**all**", rows)]:
        errors = [r["error_arcsec"] for r in group]
        if not errors:
            continue
        lines.append(f"| {label} | {len(errors)} | {percentile(errors, 50):.2f} | {percentile(errors, 90):.2f} | "
                     f"{max(errors):.2f} | {sum(e >= 1.0 for e in errors)} | "
                     f"{max(r['served_error_arcsec'] for r in group):.2f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.sync_residual", description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=52, help="centrings, spread over Dec 0.2, 30, 60, -60 (default 52)")
    parser.add_argument("--speed", type=float, default=4.0, help="emulator clock rate (default 4x real time)")
    parser.add_argument("--baud", type=int, default=9600, help="emulator line rate (default 9600)")
    parser.add_argument("--seed", type=int, default=24)
    args = parser.parse_args(argv)
    rng = random.Random(args.seed)
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-sync"
    argv_used = sys.argv[1:] if argv is None else argv
    meta: dict[str, Any] = {"command": shlex.join(["python", "-m", "benchmarks.sync_residual", *argv_used]),
                            "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                            "speed": args.speed, "baud": args.baud, "seed": args.seed, "commit": _commit(),
                            "loadavg_start": os.getloadavg()}
    started = time.time()
    rows: list[dict[str, Any]] = []
    per_dec = math.ceil(args.n / len(DECLINATIONS))
    with tempfile.TemporaryDirectory() as work:
        bench = Bench(args.speed, args.baud, Path(work))
        try:
            for dec in DECLINATIONS:
                lst = float(bench.client.get("siderealtime"))
                bench.slew(lst + 1.5, dec)  # HA -1.5 h: no meridian flip in the way
                for _ in range(min(per_dec, args.n - len(rows))):
                    rows.append(bench.centring(rng))
                    print(f"[{time.strftime('%H:%M:%S')}] {len(rows)}/{args.n} {rows[-1]}", flush=True)
        finally:
            bench.close()
    meta.update(duration_s=round(time.time() - started, 1), loadavg_end=os.getloadavg())
    save(stamp, {"meta": meta, "rows": rows}, render)
    return 0


def save(stamp: str, results: dict[str, Any], render: Callable[[dict[str, Any]], str]) -> None:
    """Write ``results/<stamp>.json`` (every number) and ``.md`` (the table ``render`` makes), print the table."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / f"{stamp}.json").write_text(json.dumps(results, indent=1))
    table = render(results)
    (RESULTS / f"{stamp}.md").write_text(table)
    print(table)


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10,
                              cwd=Path(__file__).resolve().parent).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


if __name__ == "__main__":
    sys.exit(main())
