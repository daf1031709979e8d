"""The page's log view: a bounded in-memory copy of the ``alpaca_zwo`` log, live and as a download.

Users report problems from the field with no shell at hand; a bounded copy of the log (whatever
level the server runs at) lets them download it from the page they already have open, without the
server writing anything it was not configured to write.
"""

from __future__ import annotations

import collections
import dataclasses
import itertools
import logging
import threading
from dataclasses import dataclass
from datetime import datetime, timezone

import falcon

from .http import ApiError, api_errors, check_same_origin, query_float, read_json, send, text_download

#: How many log records the page can show and download.
LOG_LINES = 2000
#: How many records one live-view poll returns at most.
ENTRIES_PER_POLL = 500
#: The longest message the page may put in the log (its messages are a sentence or two).
PAGE_MESSAGE_CHARS = 600

#: The page's own messages (what it told the person, refusals included): the log is their history, since
#: the page shows only the newest.
page_log = logging.getLogger("alpaca_zwo.page")


@dataclass(frozen=True)
class LogEntry:
    seq: int
    time: float
    level: str
    logger: str
    message: str


class LogBuffer(logging.Handler):
    """The last records of the ``alpaca_zwo`` logger, for the page's log view and download."""

    def __init__(self, capacity: int = LOG_LINES) -> None:
        super().__init__(logging.NOTSET)
        self._entries: collections.deque[LogEntry] = collections.deque(maxlen=capacity)
        self._seq = itertools.count(1)
        self.setFormatter(logging.Formatter("%(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        try:
            message = self.format(record)
        except Exception:  # a bad format string in some log call must not break the caller
            message = str(record.msg)
        self._entries.append(LogEntry(next(self._seq), record.created, record.levelname, record.name, message))

    def entries(self, after: int = 0) -> list[LogEntry]:
        return [e for e in list(self._entries) if e.seq > after]

    def text(self) -> str:
        lines = []
        for e in list(self._entries):
            stamp = datetime.fromtimestamp(e.time, timezone.utc).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]
            lines.append(f"{stamp}Z {e.level:<7} {e.logger}: {e.message}")
        return "\n".join(lines) + ("\n" if lines else "")


_log_buffer: LogBuffer | None = None
_log_buffer_lock = threading.Lock()


def log_buffer() -> LogBuffer:
    """The process-wide buffer, attached once however many servers a process starts (tests start many)."""
    global _log_buffer
    with _log_buffer_lock:
        if _log_buffer is None:
            _log_buffer = LogBuffer()
            logging.getLogger("alpaca_zwo").addHandler(_log_buffer)
        return _log_buffer


class LogResource:
    """``GET /setup/api/log[?after=SEQ]``: new log lines since the last call, for the live log view.

    ``POST /setup/api/log`` with ``{"text": ..., "level": "error"|"info"}``: a message the page showed,
    kept in the log (one line, bounded), so a refusal made from the page is in the history a user downloads.
    """

    def __init__(self, logs: LogBuffer) -> None:
        self.logs = logs

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        with api_errors(resp):
            after = int(query_float(req, "after"))
            entries = self.logs.entries(after)[-ENTRIES_PER_POLL:]
            send(resp, {"entries": [dataclasses.asdict(e) for e in entries]})

    def on_post(self, req: falcon.Request, resp: falcon.Response) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = read_json(req, 8 * PAGE_MESSAGE_CHARS)
            text, level = body.get("text"), body.get("level", "info")
            if not isinstance(text, str) or not text.strip():
                raise ApiError(400, "text: give the words the page showed")
            if level not in ("error", "info"):
                raise ApiError(400, "level must be error or info")
            # One line of printable text: no newline or control character can forge another line.
            words = " ".join("".join(c if c.isprintable() else " " for c in text).split())
            if len(words) > PAGE_MESSAGE_CHARS:
                words = words[:PAGE_MESSAGE_CHARS - 1] + "\u2026"
            page_log.log(logging.WARNING if level == "error" else logging.INFO, "page (%s) said: %s",
                         req.remote_addr, words)
            send(resp, {"logged": words})


class LogText:
    """``GET /setup/api/log.txt``: the buffered log as a file, to attach to a bug report."""

    def __init__(self, logs: LogBuffer) -> None:
        self.logs = logs

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        text_download(resp, self.logs.text(), "alpaca-zwo-log")
