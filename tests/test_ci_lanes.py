"""The whole-suite run's lanes (scripts/lanes.py) together run every test exactly once.

A new test folder or file at the top of tests/ must land in a lane by itself, never fall out of CI.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from collections import Counter
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


def test_the_lanes_collect_the_whole_suite_each_test_once() -> None:
    collected = {lane: Counter(_collected(*paths)) for lane, paths in _lanes().items()}
    whole = Counter(_collected())  # a Counter: a few generated tests (schemathesis) share a node id
    assert all(collected.values()), "a lane collects nothing"
    lanes = list(collected.values())
    assert all(not set(a) & set(b) for i, a in enumerate(lanes) for b in lanes[i + 1:]), "a test runs in two lanes"
    together = sum(lanes, Counter())
    assert together == whole, f"lanes miss {sorted(whole - together)[:5]}, add {sorted(together - whole)[:5]}"


def test_the_background_lanes_hold_the_nights_conformance_and_the_system_tests() -> None:
    lanes = _lanes()
    assert lanes["field"] == ["tests/motion", "tests/faults"]
    assert lanes["conformance"] == ["tests/conformance", "--ignore=tests/conformance/test_conformu_presets.py",
                                    "--ignore=tests/conformance/test_conformu_sites.py"]
    assert lanes["sites"] == ["tests/conformance/test_conformu_sites.py"]
    assert lanes["firmware"] == ["tests/conformance/test_conformu_presets.py"]
    assert lanes["platform"] == ["tests/platform"]
    elsewhere = {"tests/conformance", "tests/platform", "tests/motion", "tests/faults"}
    assert not elsewhere & set(lanes["main"])
