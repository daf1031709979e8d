"""The whole-suite run's two lanes (scripts/lanes.py) together run every test exactly once.

A new test folder or file at the top of tests/ must land in a lane by itself, never fall out of CI.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _lanes() -> dict[str, list[str]]:
    spec = importlib.util.spec_from_file_location("lanes", REPO / "scripts" / "lanes.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    found: dict[str, list[str]] = module.lanes(REPO)
    return found


def _collected(*paths: str) -> list[str]:
    done = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", *paths],
                          capture_output=True, text=True, cwd=REPO, timeout=300)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return [line for line in done.stdout.splitlines() if "::" in line]


def test_the_two_lanes_collect_the_whole_suite_each_test_once() -> None:
    lanes = _lanes()
    platform, main = _collected(*lanes["platform"]), _collected(*lanes["main"])
    whole = _collected()
    assert platform and main
    assert not set(platform) & set(main), "a test runs in both lanes"
    assert sorted(platform + main) == sorted(whole), (
        f"lanes miss {sorted(set(whole) - set(platform) - set(main))[:5]}, "
        f"add {sorted(set(platform) | set(main) - set(whole))[:5]}")


def test_conformance_runs_last_and_the_platform_lane_holds_only_system_tests() -> None:
    lanes = _lanes()
    assert lanes["main"][-1] == "tests/conformance"
    assert lanes["platform"] == ["tests/platform"]
