"""Which page each screenshot in docs/screenshots/ shows, so the docs never show an older page than the one served.

A file's modification time means nothing in a git checkout, so "older" is decided by content: when a
screenshot is recorded, docs/screenshots/MANIFEST.json keeps the SHA-256 of the PNG and of the page's
sources at that moment (every file of static/ except the guide's own guide.css). A screenshot is stale
when the page's sources now hash differently, and unrecorded when its PNG differs from the one recorded.

Taking them: the browser tests write each view to /tmp/alpaca-zwo-<view>-<phone|desktop>.png (each
entry's ``taken_by`` names the test); copy the ones the docs use into docs/screenshots/ under their names
here, then record them:

    python3 -m tools.screenshots record handset-progress-phone.png ...   (or: record --all)
    python3 -m tools.screenshots check                                  (what tests/test_docs.py runs)
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
#: The browser test that writes each screenshot, and its file in /tmp (by the screenshot's name prefix).
TAKEN_BY = {
    "handset-": "tests/browser/test_page_handset.py (/tmp/alpaca-zwo-handset-<view>-<size>.png)",
    "chart-card-": "tests/browser/test_page_in_the_dark.py (/tmp/alpaca-zwo-chart-card-<size>.png)",
    "chart-night-": "tests/browser/test_page_skychart.py (/tmp/alpaca-zwo-chart-night-<size>-greenwich.png)",
    "chart-": "tests/browser/test_page_skychart.py (/tmp/alpaca-zwo-chart-<view>-<size>.png)",
    "night-top-": "tests/browser/test_page_in_the_dark.py (/tmp/alpaca-zwo-night-top-<size>.png)",
    "stop-refused-": "tests/browser/test_page_in_the_dark.py (/tmp/alpaca-zwo-stop-refused-<size>.png)",
    "search-": "tests/browser/test_page_search.py (/tmp/alpaca-zwo-search-<view>-<size>.png)",
    "page-link-lost-": "tests/browser/test_page_first_contact.py (/tmp/alpaca-zwo-first-contact-link-lost-<size>.png)",
    "page-location-": "tests/browser/test_page_first_contact.py (/tmp/alpaca-zwo-first-contact-location-<size>.png)",
}


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
            found.append(f"docs/screenshots/{path.name} shows an older page than static/ now: retake it "
                         f"({entry.get('taken_by', 'tests/browser')} writes /tmp/alpaca-zwo-*.png), copy it "
                         f"here, then run {COMMAND} {path.name}")
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
    return next((test for prefix, test in TAKEN_BY.items() if name.startswith(prefix)), "tests/browser")


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
    if argv[:1] in (["record"], ["backfill"]) and len(argv) > 1:
        names = [p.name for p in sorted(SHOTS.glob("*.png"))] if argv[1] == "--all" else argv[1:]
        (record if argv[0] == "record" else backfill)(names)
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
