"""ConformU's log and its counters, shared by the conformance and the protocol suite.

The levels and what counts follow checklist §2 (conformance: ISSUE and ERROR count, OK and INFO do
not) and §C.2 (protocol: INFO counts against a clean run as well). The rendered log reads like
ConformU's ``conform.report``: one line per check, so a failing CI run shows exactly which check
failed and with what reply.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum


class Level(str, Enum):
    OK = "OK"
    INFO = "INFO"
    ISSUE = "ISSUE"
    ERROR = "ERROR"
    DEBUG = "DEBUG"
    SECTION = ""


@dataclass(frozen=True)
class Entry:
    elapsed: float  # real seconds since the report started
    level: Level
    test: str
    message: str
    detail: str = ""


@dataclass
class Report:
    """Every message of one run, in order, with the counts ConformU prints at the end."""

    name: str
    entries: list[Entry] = field(default_factory=list)
    started: float = field(default_factory=time.monotonic)

    def log(self, level: Level, test: str, message: str, detail: str = "") -> None:
        self.entries.append(Entry(time.monotonic() - self.started, level, test, message, detail))

    def ok(self, test: str, message: str, detail: str = "") -> None:
        self.log(Level.OK, test, message, detail)

    def info(self, test: str, message: str, detail: str = "") -> None:
        self.log(Level.INFO, test, message, detail)

    def issue(self, test: str, message: str, detail: str = "") -> None:
        self.log(Level.ISSUE, test, message, detail)

    def error(self, test: str, message: str, detail: str = "") -> None:
        self.log(Level.ERROR, test, message, detail)

    def debug(self, test: str, message: str) -> None:
        self.log(Level.DEBUG, test, message)

    def section(self, title: str) -> None:
        self.log(Level.SECTION, title, "")

    def count(self, level: Level) -> int:
        return sum(1 for e in self.entries if e.level is level)

    @property
    def errors(self) -> int:
        return self.count(Level.ERROR)

    @property
    def issues(self) -> int:
        return self.count(Level.ISSUE)

    @property
    def infos(self) -> int:
        return self.count(Level.INFO)

    def findings(self, *levels: Level) -> list[Entry]:
        return [e for e in self.entries if e.level in levels]

    def render(self, *, debug: bool = False) -> str:
        lines = []
        for e in self.entries:
            if e.level is Level.DEBUG and not debug:
                continue
            if e.level is Level.SECTION:
                lines.append("")
                lines.append(e.test)
                continue
            line = f"{e.elapsed:8.2f} {e.test:<42} {e.level.value:<6} {e.message}"
            if e.detail:
                line += f"\n{'':58}{e.detail}"
            lines.append(line)
        return "\n".join(lines)

    def summary(self) -> str:
        findings = self.findings(Level.ERROR, Level.ISSUE)
        lines = [f"{len(findings)} error(s) and issue(s):"] if findings else []
        lines += [f"  {e.level.value:<6} {e.test}: {e.message}" for e in findings]
        return "\n".join(lines)


#: Finished runs in this pytest session, for the terminal summary (tests/conformance/conftest.py).
RESULTS: list[tuple[str, Report]] = []
