"""The lanes of a whole-suite run (scripts/run-tests with no test paths): six pytest processes side by side.

The suite waits far more than it computes (emulated slews, real-time pulses, ConformU's timed checks:
about 6 CPU minutes in a 47-minute serial run on two cores), so independent groups overlap well:

- ``main``: every test folder and file but those below, in the foreground at normal priority.
- ``field``: the emulated nights (tests/motion: slews, flips and guiding at three sites; tests/faults:
  WiFi stalls and outages, the soak), in the background at normal priority: the largest share of the
  suite's waiting, about half of what was one 50-minute main lane, so the two halves wait at the
  same time.
- ``conformance``: the ConformU reproduction north of the equator (about 17 minutes, most of it waiting
  on emulated time), in the background at normal priority: its timed checks must not be starved.
- ``sites``: the ConformU conformance run at Sydney and on the equator (issue 30; about 20 minutes,
  waiting as the other), carved out of ``tests/conformance`` into a lane of its own beside it, so the
  two halves wait at the same time instead of one after the other.
- ``firmware``: the ConformU conformance run against the real-transcript firmware preset ``am5-1.8.8``
  (issue 39 item 4: north and at Sydney, equatorial and alt-az; about 30 minutes, 9 per equatorial run
  and 6 per alt-az one), carved out the same way into a lane of its own: the same waiting on emulated
  time, overlapped with the other two ConformU lanes.
- ``platform``: the system tests (fresh Debian roots, the container image, wheels, the start-at-boot unit):
  they wait on dpkg, pip and podman, never time the server and have minutes of slack, so they run in
  the background at a lower CPU and disk priority.

``tests/test_ci_lanes.py`` checks that the lanes together collect exactly the whole suite, each test once.

    python3 scripts/lanes.py main|field|conformance|sites|firmware|platform   # one pytest argument per line
    python3 scripts/lanes.py --background                           # the lanes run beside main, one a line
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: lane -> the entries of tests/ it runs, or a test file carved out of another lane's entry (that lane
#: then ignores it); ``main`` takes every other entry.
SEPARATE = {"field": ("tests/motion", "tests/faults"), "conformance": ("tests/conformance",),
            "sites": ("tests/conformance/test_conformu_sites.py",),
            "firmware": ("tests/conformance/test_conformu_presets.py",),
            "platform": ("tests/platform",)}
LANES = ("main", *SEPARATE)


def lanes(root: Path = ROOT) -> dict[str, list[str]]:
    """Each lane's pytest arguments: every entry of tests/ that holds tests in exactly one lane, a
    carved-out file in its own lane and ignored by the lane of the entry it lies in."""
    tests = root / "tests"
    entries = sorted(p.relative_to(root).as_posix() for p in tests.iterdir()
                     if (any(p.rglob("test_*.py")) if p.is_dir() else p.match("test_*.py")))
    taken = {entry for paths in SEPARATE.values() for entry in paths}
    carved = [path for path in taken if path not in entries]
    found = {}
    for lane, paths in SEPARATE.items():
        own = [p for p in paths if p in entries or p in carved]
        inside = [c for c in carved if c not in paths and any(c.startswith(f"{p}/") for p in own)]
        found[lane] = own + [f"--ignore={c}" for c in sorted(inside)]
    return {"main": [e for e in entries if e not in taken], **found}


if __name__ == "__main__":
    if sys.argv[1:] == ["--background"]:
        print("\n".join(SEPARATE))
        sys.exit(0)
    if len(sys.argv) != 2 or sys.argv[1] not in LANES:
        sys.exit(f"usage: python3 scripts/lanes.py {'|'.join(LANES)}")
    print("\n".join(lanes()[sys.argv[1]]))
