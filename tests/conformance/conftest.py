"""Adds ConformU's result lines to pytest's terminal summary, so they show in CI even when green."""

from __future__ import annotations

import pytest


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    from tests.conformance.report import RESULTS

    for suite, report in RESULTS:
        if suite.startswith("alpacaprotocol"):
            line = f"{suite}: {report.errors} errors, {report.issues} issues, {report.infos} information"
        else:
            line = f"{suite}: {report.errors} errors, {report.issues} issues"
        terminalreporter.write_line(line)
