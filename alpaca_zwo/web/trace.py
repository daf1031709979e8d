"""The serial trace view: the recent exchanges with the mount, live and as a download."""

from __future__ import annotations

from datetime import datetime, timezone

import falcon

from .context import Resource
from .http import api_errors, query_float, send, text_download

#: How many exchanges one live-view poll returns at most.
TRACE_LIMIT = 500


class TraceResource(Resource):
    """``GET /setup/api/telescope/{number}/trace[?after=T]``: the recent serial exchanges, oldest first."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            after = query_float(req, "after")
            entries = [e for e in device.trace() if e.time > after][-TRACE_LIMIT:]
            send(resp, {"entries": [{"time": e.time, "request": e.request, "reply": e.reply,
                                     "duration_ms": round(e.duration_ms, 2), "note": e.note} for e in entries]})


class TraceText(Resource):
    """``GET /setup/api/telescope/{number}/trace.txt``: the whole trace buffer as a download."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            lines = []
            for e in device.trace():
                stamp = datetime.fromtimestamp(e.time, timezone.utc).strftime("%H:%M:%S.%f")[:-3]
                reply = "(no reply)" if e.reply is None else e.reply
                lines.append(f"{stamp}Z {e.duration_ms:8.1f} ms  {e.request!s:<16} -> {reply}  {e.note}".rstrip())
            text_download(resp, "\n".join(lines) + "\n", f"alpaca-zwo-trace-{device.index}")
