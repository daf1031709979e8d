"""Which page each screenshot in docs/screenshots/ shows, so the docs never show an older page than the one served.

A file's modification time means nothing in a git checkout, so "older" is decided by content: when a
screenshot is recorded, docs/screenshots/MANIFEST.json keeps the SHA-256 of the PNG and of the page's
sources at that moment (every file of static/ except the guide's own guide.css). A screenshot is stale
when the page's sources now hash differently, and unrecorded when its PNG differs from the one recorded.

Taking them: the browser tests write each view to /tmp/alpaca-zwo-<view>-<phone|desktop>.png (each
entry's ``taken_by`` names the test and the file). /tmp is shared by every program on the machine, and
another checkout's browser tests write the same names: run them with a /tmp of their own and copy the
files out (as root: ``unshare -m sh -c 'mount -t tmpfs none /tmp && <the tests> ; cp /tmp/alpaca-zwo-*.png
DIR/'``), then record them:

    scripts/run-tests tests/browser/test_page_handset.py tests/browser/test_page_in_the_dark.py \\
        tests/browser/test_page_skychart.py tests/browser/test_page_search.py \\
        tests/browser/test_page_first_contact.py tests/browser/test_page_messages.py \\
        tests/browser/test_page_connect.py tests/browser/test_page_first_site.py tests/browser/test_page_jog.py \\
        tests/browser/test_page_meridian.py tests/browser/test_page_observatory.py
    python3 -m tools.screenshots collect --from DIR --all   (copies and records; or name the screenshots)
    python3 -m tools.screenshots record NAME...    (a screenshot put in docs/screenshots/ by hand)
    python3 -m tools.screenshots check             (what tests/test_docs.py runs)
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SHOTS = ROOT / "docs" / "screenshots"
MANIFEST = SHOTS / "MANIFEST.json"
STATIC = ROOT / "static"
#: static/ files that are not the setup page shown in the screenshots.
NOT_THE_PAGE = {"guide.css"}
COMMAND = "python3 -m tools.screenshots record"
_HANDSET = "tests/browser/test_page_handset.py"
_DARK = "tests/browser/test_page_in_the_dark.py"
_CHART = "tests/browser/test_page_skychart.py"
_SEARCH = "tests/browser/test_page_search.py"
_FIRST = "tests/browser/test_page_first_contact.py"
_MESSAGES = "tests/browser/test_page_messages.py"
#: Each screenshot's browser test and the file it writes in /tmp, by the screenshot's name without its size.
SOURCES = {
    **{f"handset-{view}": (_HANDSET, f"handset-{view}-{{size}}")
       for view in ("arrival", "progress", "search-list", "selection", "sun-confirm")},
    "chart-card": (_DARK, "chart-card-{size}"),
    "night-top": (_DARK, "night-top-{size}"),
    "stop-refused": (_DARK, "stop-refused-{size}"),
    "chart-day": (_CHART, "chart-day-{size}"),
    "chart-south": (_CHART, "chart-south-{size}"),
    "chart-night": (_CHART, "chart-night-{size}-{site}"),  # the phone's at a northern site, the desktop's southern
    "search-ambiguous": (_SEARCH, "search-ambiguous-{size}"),
    "search-times": (_SEARCH, "search-times-{size}"),
    "page-link-lost": (_FIRST, "first-contact-link-lost-{size}"),
    "page-location": (_FIRST, "first-contact-location-{size}"),
    "refusal": (_MESSAGES, "refusal-{size}"),
    "stopped": (_MESSAGES, "stopped-{size}"),
    **{view: (f"tests/browser/test_page_{module}.py", f"{view}-{{size}}")
       for view, module in (("connect", "connect"), ("first-site", "first_site"), ("jog", "jog"),
                            ("meridian", "meridian"), ("observatory", "observatory"))},
}


def source(name: str, folder: Path = Path("/tmp")) -> tuple[str, Path] | None:
    """The test that takes screenshot ``name`` (``chart-day-phone.png``) and where it writes it."""
    stem, _, size = name.removesuffix(".png").rpartition("-")
    if stem not in SOURCES:
        return None
    test, pattern = SOURCES[stem]
    site = "north" if size == "phone" else "south"
    return test, folder / f"alpaca-zwo-{pattern.format(size=size, site=site)}.png"


def page_hash(files: dict[str, bytes]) -> str:
    """One hash of the page's sources: each file's name and content, in name order."""
    digest = hashlib.sha256()
    for name in sorted(files):
        if name not in NOT_THE_PAGE:
            digest.update(name.encode() + b"\0" + hashlib.sha256(files[name]).digest())
    return digest.hexdigest()


def current_page_hash() -> str:
    return page_hash({path.name: path.read_bytes() for path in STATIC.iterdir() if path.is_file()})


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def manifest() -> dict[str, Any]:
    data: dict[str, Any] = json.loads(MANIFEST.read_text(encoding="utf-8"))
    return data


def problems() -> list[str]:
    """One line per screenshot that is unrecorded, replaced since it was recorded, or older than the page."""
    entries = manifest()["screenshots"]
    now = current_page_hash()
    found = []
    for path in sorted(SHOTS.glob("*.png")):
        entry = entries.get(path.name)
        if entry is None:
            found.append(f"docs/screenshots/{path.name} is not recorded: run {COMMAND} {path.name}")
        elif entry["png_sha256"] != _sha(path):
            found.append(f"docs/screenshots/{path.name} changed since it was recorded: run {COMMAND} {path.name}")
        elif entry["page_sha256"] != now:
            found.append(f"docs/screenshots/{path.name} shows an older page than static/ now: retake it with "
                         f"{_taken_by(path.name)} and collect it (python3 -m tools.screenshots says how)")
    found += [f"MANIFEST.json names {name}, which is not in docs/screenshots/" for name in sorted(entries)
              if not (SHOTS / name).is_file()]
    return found


def _save(data: dict[str, Any]) -> None:
    MANIFEST.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n", encoding="utf-8")


def record(names: list[str]) -> None:
    """Record these screenshots as taken of the page as it is now."""
    data = manifest() if MANIFEST.is_file() else {"how": __doc__.split("\n\n", 1)[1].strip(), "screenshots": {}}
    now = current_page_hash()
    for name in names:
        entry = data["screenshots"].setdefault(name, {})
        entry.update(png_sha256=_sha(SHOTS / name), page_sha256=now, taken_by=_taken_by(name))
    _save(data)


def _taken_by(name: str) -> str:
    found = source(name)
    return f"{found[0]} ({found[1]})" if found else "tests/browser"


def collect(names: list[str], folder: Path) -> list[str]:
    """Copy the screenshots the browser tests just wrote (to /tmp, here ``folder``) into docs/screenshots/,
    and record them. Returns the names whose file was not found (their test did not run, or failed first)."""
    missing, taken = [], []
    for name in names:
        found = source(name, folder)
        if found is None or not found[1].is_file():
            missing.append(name)
            continue
        (SHOTS / name).write_bytes(found[1].read_bytes())
        taken.append(name)
    record(taken)
    return missing


def _git(*args: str) -> bytes:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, check=True).stdout


def backfill(names: list[str]) -> None:
    """Record screenshots as of the commit that last changed each: the page's sources at that commit."""
    data = manifest() if MANIFEST.is_file() else {"how": __doc__.split("\n\n", 1)[1].strip(), "screenshots": {}}
    for name in names:
        commit = _git("log", "-1", "--format=%H", "--", f"docs/screenshots/{name}").decode().strip()
        files = {Path(line).name: _git("show", f"{commit}:{line}")
                 for line in _git("ls-tree", "-r", "--name-only", commit, "static/").decode().split()}
        entry = data["screenshots"].setdefault(name, {})
        entry.update(png_sha256=_sha(SHOTS / name), page_sha256=page_hash(files), taken_by=_taken_by(name),
                     recorded_at_commit=commit)
    _save(data)


def main(argv: list[str]) -> int:
    if argv[:1] == ["check"]:
        for line in problems():
            print(line, file=sys.stderr)
        return 1 if problems() else 0
    folder = Path("/tmp")
    if len(argv) > 2 and argv[1] == "--from":
        folder, argv = Path(argv[2]), [argv[0], *argv[3:]]
    if argv[:1] in (["record"], ["backfill"], ["collect"]) and len(argv) > 1:
        names = [p.name for p in sorted(SHOTS.glob("*.png"))] if argv[1] == "--all" else argv[1:]
        if argv[0] == "collect":
            missing = collect(names, folder)
            for name in missing:
                print(f"{name}: its browser test wrote no file in /tmp ({_taken_by(name)})", file=sys.stderr)
            return 1 if missing else 0
        (record if argv[0] == "record" else backfill)(names)
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
