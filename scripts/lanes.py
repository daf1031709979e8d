"""The two lanes of a whole-suite run (scripts/run-tests with no test paths), side by side on two cores.

Lane ``platform`` is the system tests (fresh Debian roots, the container image, wheels, the start-at-boot
unit): they wait on dpkg, pip and podman, never time the server, and have minutes of slack; they run in the
background at a lower CPU and disk priority. Lane ``main`` is everything else at normal priority, with the
ConformU runs named last (pytest runs its arguments in order), so they mostly run after the platform lane
has finished. ``tests/test_ci_lanes.py`` checks that the two lanes together collect exactly the whole suite.

    python3 scripts/lanes.py platform|main    # one argument per line, for run-tests
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: Run in the background lane, at lower priority.
BACKGROUND = ("tests/platform",)
#: Run at the end of the main lane: long and CPU-heavy (ConformU), best alone.
LAST = ("tests/conformance",)


def lanes(root: Path = ROOT) -> dict[str, list[str]]:
    """Each lane's pytest path arguments: every entry of tests/ in exactly one lane, sorted, LAST at the end."""
    tests = root / "tests"
    entries = sorted(p.relative_to(root).as_posix() for p in tests.iterdir()
                     if (any(p.rglob("test_*.py")) if p.is_dir() else p.match("test_*.py")))
    main = [e for e in entries if e not in BACKGROUND and e not in LAST] + [e for e in LAST if e in entries]
    return {"platform": [e for e in entries if e in BACKGROUND], "main": main}


if __name__ == "__main__":
    if len(sys.argv) != 2 or sys.argv[1] not in ("platform", "main"):
        sys.exit("usage: python3 scripts/lanes.py platform|main")
    print("\n".join(lanes()[sys.argv[1]]))
