"""Adds ConformU's result lines to pytest's terminal summary, so they show in CI even when green."""

from __future__ import annotations

from collections.abc import Iterator

import pytest


@pytest.fixture
def conformu_client_id() -> Iterator[None]:
    """ConformU's client is ClientID 1; alpyca picks a random one, so pin it for the alpyca calls too.

    Both clients then share one connection as far as the server's per-client bookkeeping goes, as
    ConformU's single client would.
    """
    from alpaca.device import Device

    saved = Device._client_id
    Device._client_id = 1
    yield
    Device._client_id = saved


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    from tests.conformance.report import RESULTS

    for suite, report in RESULTS:
        if suite.startswith("alpacaprotocol"):
            line = f"{suite}: {report.errors} errors, {report.issues} issues, {report.infos} information"
        else:
            line = f"{suite}: {report.errors} errors, {report.issues} issues"
        terminalreporter.write_line(line)
