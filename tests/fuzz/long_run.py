"""The long schemathesis run: at least 20,000 generated requests against a live server, then a summary.

Same schemas, routing and checks as the CI test (``alpaca_fuzz.py``), in two stages:

1. Fuzzing, collect-all: every operation, positive and negative data, round after round until the
   request target is reached. It never stops at a failure: every case runs, every problem is counted
   with one example. Then the consistency check (the server still serves, the state hangs together,
   a restore-site + home + track + GOTO session works).
2. The CI pytest test with many more random examples, which adds schemathesis' examples and
   coverage phases (boundary values, missing parameters, undefined verbs); hypothesis stops an
   operation at its first failure there, so this stage reports failing operations.

    python -m tests.fuzz.long_run                 # >= 20,000 requests in stage 1, random seed
    python -m tests.fuzz.long_run --requests 50000 --seed 7 --json result.json

Exit status 0 only if both stages found nothing and the final consistency check passed.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import random
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import Any

import hypothesis
import hypothesis.errors
import schemathesis
from hypothesis import HealthCheck, Phase, given, settings
from schemathesis import Case, GenerationMode

from tests.fuzz.alpaca_fuzz import (
    FUZZ_SPEED,
    LiveServer,
    Stats,
    check_consistent,
    exercise,
    start_live_server,
)
from tests.fuzz.spec_fixes import load_device_schema, load_management_schema


def fuzz_operation(operation: Any, mode: GenerationMode, examples: int, seed: int, live: LiveServer,
                   base_path: str, stats: Stats) -> None:
    """Run ``examples`` generated cases of one operation, recording every problem instead of stopping."""

    @given(case=operation.as_strategy(generation_mode=mode))
    @settings(max_examples=examples, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @hypothesis.seed(seed)
    def one(case: Case) -> None:
        try:
            exercise(case, live.base_url + base_path, live.keeper.session, stats)
            live.keeper.after(case)
            if stats.requests % 500 == 0:
                live.keeper.check_state()
        except Exception as exc:  # a long run records everything and carries on
            stats.record_problem(f"harness/invariant: {type(exc).__name__}: {str(exc)[:100]}",
                                 "".join(traceback.format_exception(exc))[-2000:])

    # Negative data for an operation without parameters cannot be generated: nothing to break there.
    with contextlib.suppress(hypothesis.errors.Unsatisfiable):
        one()


def run(target: int, examples: int, seed: int, config_dir: Path) -> tuple[Stats, dict[str, Any], float]:
    stats = Stats()
    live = start_live_server(config_dir / "config.toml")
    started = time.monotonic()
    rng = random.Random(seed)
    final: dict[str, Any] = {}
    try:
        schemas = [(load_device_schema(), "/api/v1"), (load_management_schema(), "")]
        operations = [(op.ok(), base) for schema, base in schemas for op in schema.get_all_operations()]
        round_number = 0
        while stats.requests < target:
            round_number += 1
            rng.shuffle(operations)
            for operation, base in operations:
                for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE):
                    fuzz_operation(operation, mode, examples, rng.randrange(2**32), live, base, stats)
            print(f"round {round_number}: {stats.requests} requests, {sum(stats.problems.values())} problems, "
                  f"{time.monotonic() - started:.0f} s", file=sys.stderr, flush=True)
        try:
            final = {"consistent": True, "state": check_consistent(live)}
        except Exception as exc:  # the report must say what broke, not just that something did
            final = {"consistent": False, "error": "".join(traceback.format_exception_only(exc)).strip()}
    finally:
        live.server.stop()
    return stats, final, time.monotonic() - started


def run_pytest_phases(examples: int, tmp: Path) -> dict[str, Any]:
    """The CI test with many more examples and random data: schemathesis' examples and coverage phases
    (boundary values, missing parameters, undefined verbs) that the fuzzing above does not generate.
    Hypothesis stops an operation at its first failure there, so this stage lists failing operations."""
    stats_path = tmp / "pytest-stats.json"
    env = {**os.environ, "ALPACA_FUZZ_EXAMPLES": str(examples), "ALPACA_FUZZ_RANDOM": "1",
           "ALPACA_FUZZ_STATS": str(stats_path)}
    started = time.monotonic()
    result = subprocess.run([sys.executable, "-m", "pytest", str(Path(__file__).with_name("test_schemathesis.py")),
                             "-q", "-rf", "-p", "no:cacheprovider", "--timeout", "3600"],
                            env=env, capture_output=True, text=True, cwd=Path(__file__).parents[2], check=False)
    lines = result.stdout.splitlines()
    stats = json.loads(stats_path.read_text(encoding="utf-8")) if stats_path.exists() else {}
    return {
        "elapsed_s": round(time.monotonic() - started, 1),
        "exit_code": result.returncode,
        "outcome": next((line for line in reversed(lines) if " in " in line and ("passed" in line or "failed" in line)),
                        ""),
        "failed": [line.removeprefix("FAILED ").split(" - ")[0] for line in lines if line.startswith("FAILED ")],
        **stats,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--requests", type=int, default=20_000, help="minimum generated requests (default 20000)")
    parser.add_argument("--examples", type=int, default=60, help="examples per operation and mode per round")
    parser.add_argument("--seed", type=int, default=None, help="random seed (default: random)")
    parser.add_argument("--json", type=Path, default=None, help="also write the summary as JSON here")
    parser.add_argument("--pytest-examples", type=int, default=100,
                        help="examples per operation for the second stage, the pytest phases (0: skip it)")
    args = parser.parse_args(argv)
    seed = args.seed if args.seed is not None else random.randrange(2**32)

    with tempfile.TemporaryDirectory(prefix="alpaca-fuzz-") as tmp:
        stats, final, elapsed = run(args.requests, args.examples, seed, Path(tmp))
        print(f"fuzzing stage done: {stats.requests} requests; pytest phases next", file=sys.stderr, flush=True)
        phases = run_pytest_phases(args.pytest_examples, Path(tmp)) if args.pytest_examples else {}
    summary = {
        "seed": seed,
        "elapsed_s": round(elapsed, 1),
        "requests_per_s": round(stats.requests / elapsed, 1) if elapsed else None,
        "emulator_speed": FUZZ_SPEED,
        "schemathesis": schemathesis.__version__,
        "hypothesis": hypothesis.__version__,
        "python": platform.python_version(),
        **stats.summary(),
        "final_check": final,
        "pytest_phases": phases,
        "total_requests": stats.requests + int(phases.get("requests", 0)),
    }
    text = json.dumps(summary, indent=2, default=str)
    print(text)
    if args.json:
        args.json.write_text(text + "\n", encoding="utf-8")
    clean = not stats.problems and final.get("consistent") and phases.get("exit_code", 0) == 0
    return 0 if clean else 1


if __name__ == "__main__":
    sys.exit(main())
