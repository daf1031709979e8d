"""Profile alpaca-zwo's hot path once: ``python -m benchmarks.profile [--seconds 20] [--member tracking]``.

Starts the emulator and the server as separate processes (as ``benchmarks.run`` does), drives a
closed-loop saturation of one cheap GET from the load-generator processes, and samples the server
with py-spy in non-blocking mode (so the sampler does not stop the server it measures). Writes a
flame graph (SVG) and the collapsed stacks next to the results, and prints where the time goes:
functions by own time, frames by inclusive time, and own time grouped by library.
"""

from __future__ import annotations

import argparse
import collections
import shutil
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

from .client import AlpacaClient
from .loads import ClientSpec, WorkerPool
from .procs import start_alpaca_zwo, start_emulator

RESULTS = Path(__file__).resolve().parent / "results"

GROUPS = (
    ("waitress", "(waitress/"),
    ("falcon", "(falcon/"),
    ("alpaca_zwo.alpaca (HTTP layer)", "(alpaca_zwo/alpaca/"),
    ("alpaca_zwo (telescope, mount, link)", "(alpaca_zwo/"),
    ("pyserial", "(serial/"),
    ("json", "(json/"),
    ("logging", "(logging/"),
    ("urllib.parse", "(urllib/"),
    ("threading", "(threading.py"),
    ("socket", "(socket.py"),
)


def _group(frame: str) -> str:
    for name, marker in GROUPS:
        if marker in frame:
            return name
    if "(" in frame:
        return "other: " + frame.rsplit("(", 1)[1].split(":", 1)[0].rsplit("/", 1)[-1]
    return "other"


def summarise(collapsed: Path, top: int = 25) -> str:
    """Own time per function, inclusive time per frame, own time per library, from py-spy raw output."""
    own: collections.Counter[str] = collections.Counter()
    inclusive: collections.Counter[str] = collections.Counter()
    groups: collections.Counter[str] = collections.Counter()
    total = 0
    for line in collapsed.read_text().splitlines():
        stack, _, count_text = line.rpartition(" ")
        if not stack:
            continue
        count = int(count_text)
        frames = [f for f in stack.split(";") if f and not f.startswith("process ") and not f.startswith("thread ")]
        if not frames:
            continue
        total += count
        own[frames[-1]] += count
        groups[_group(frames[-1])] += count
        for frame in set(frames):
            inclusive[frame] += count
    out = [f"{total} samples of active (non-idle) threads", "", "Own time by library:"]
    out += [f"  {100.0 * c / total:5.1f}%  {name}" for name, c in groups.most_common()]
    out += ["", f"Top {top} functions by own time:"]
    out += [f"  {100.0 * c / total:5.1f}%  {name}" for name, c in own.most_common(top)]
    out += ["", f"Top {top} frames by inclusive time:"]
    out += [f"  {100.0 * c / total:5.1f}%  {name}" for name, c in inclusive.most_common(top)]
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.profile", description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--member", default="tracking", help="the GET to saturate (default tracking)")
    parser.add_argument("--connections", type=int, default=16)
    parser.add_argument("--rate", type=int, default=250, help="py-spy samples per second")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    if shutil.which("py-spy") is None:
        print("py-spy is not installed: pip install py-spy", file=sys.stderr)
        return 2
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ") + "-profile"
    run_dir = RESULTS / stamp
    run_dir.mkdir(parents=True)
    emulator = start_emulator(run_dir, 9600, None)
    server = start_alpaca_zwo(run_dir, emulator.proc.ports["tcp"], None)
    pool = WorkerPool(args.workers)
    try:
        anchor = AlpacaClient("127.0.0.1", server.port, client_id=7, timeout=30.0)
        anchor.put("connected", Connected="true")
        specs = [ClientSpec("saturate", args.connections, args.member, {"member": args.member})]
        running = pool.start("127.0.0.1", server.port, specs, warmup=1.0, duration=args.seconds + 2.0)
        time.sleep(max(0.0, running.measure_from - time.time()))
        gil, wall, svg = run_dir / "gil.collapsed.txt", run_dir / "wall.collapsed.txt", run_dir / "gil.svg"
        # --gil: only the thread holding the GIL, i.e. where the server's one core of Python goes;
        # without it: every non-idle thread, so time in send()/recv() system calls shows up too.
        for flags, fmt, path in ((["--gil", "-F"], "raw", gil), (["-F"], "raw", wall), (["--gil"], "flamegraph", svg)):
            subprocess.run(["py-spy", "record", "--nonblocking", *flags, "--rate", str(args.rate), "--duration",
                            str(max(1, int(args.seconds / 3))), "--format", fmt, "--output", str(path), "--pid",
                            str(server.pid)], check=True, capture_output=True, timeout=args.seconds + 60)
        result = running.wait()
        anchor.close()
        entry = result["labels"][args.member]
        window = result["window"][1] - result["window"][0]
        text = ("== GIL holder (Python CPU) ==\n" + summarise(gil)
                + "\n\n== all non-idle threads (incl. system calls) ==\n" + summarise(wall, top=15))
        header = (f"py-spy ({args.rate} Hz, non-blocking) on alpaca-zwo pid {server.pid} while {args.connections} "
                  f"connections saturate GET {args.member}: {entry['ok'] / window:.0f} req/s, "
                  f"{entry['errors']} errors (sampling costs the server some throughput)\n")
        (run_dir / "summary.txt").write_text(header + text + "\n")
        print(header + text)
        print(f"\nflame graph: {svg}\ncollapsed stacks: {gil}, {wall}")
    finally:
        pool.close()
        server.stop()
        emulator.proc.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
