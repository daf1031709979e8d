"""A minimal keep-alive HTTP/1.1 Alpaca client that validates every reply.

Raw sockets rather than ``requests``: on a 2-core machine the load generator shares the CPU with
the server under test, and ``requests`` spends roughly ten times more CPU per call than this, CPU
that would otherwise go to the server and would blur the comparison between servers. Each reply
is still checked in full: HTTP 200, a JSON body, ErrorNumber 0, the ClientTransactionID echoed,
and a Value of the expected JSON type for the member read.
"""

from __future__ import annotations

import json
import socket
import time
from typing import Any
from urllib.parse import urlencode

__all__ = ["VALUE_TYPES", "AlpacaClient", "ReplyError", "parse_iso_utc"]

#: JSON type each property read must come back as (NINA's client type-checks these too).
VALUE_TYPES: dict[str, tuple[type, ...]] = {
    "connected": (bool,),
    "atpark": (bool,),
    "athome": (bool,),
    "tracking": (bool,),
    "cansettracking": (bool,),
    "cansetguiderates": (bool,),
    "canpulseguide": (bool,),
    "canslew": (bool,),
    "ispulseguiding": (bool,),
    "slewing": (bool,),
    "trackingrate": (int,),
    "sideofpier": (int,),
    "declinationrate": (int, float),
    "rightascensionrate": (int, float),
    "altitude": (int, float),
    "azimuth": (int, float),
    "declination": (int, float),
    "rightascension": (int, float),
    "siderealtime": (int, float),
    "guideraterightascension": (int, float),
    "guideratedeclination": (int, float),
    "utcdate": (str,),
    "devicestate": (list,),
}


class ReplyError(Exception):
    """A reply that a real client would have treated as a failure (or no reply at all)."""


class _Closed(Exception):
    """The server closed the connection before any byte of the reply arrived."""


def parse_iso_utc(text: str) -> float:
    """Seconds since the epoch for an Alpaca ISO-8601 UTC stamp (7 fractional digits, trailing Z).

    Hand-parsed because ``datetime.fromisoformat`` on Python 3.10 rejects both the ``Z`` and the
    seventh digit that .NET-style Alpaca servers send.
    """
    import calendar

    body = text.rstrip("Z")
    main, _, frac = body.partition(".")
    stamp = calendar.timegm(time.strptime(main, "%Y-%m-%dT%H:%M:%S"))
    return stamp + (float("0." + frac) if frac else 0.0)


class AlpacaClient:
    """One keep-alive connection to one Alpaca device, like one client application's.

    Not thread-safe: each simulated client owns its own instance. ``latency`` holds the duration
    of the last call in seconds, from just before the request is written to the last reply byte.
    """

    def __init__(self, host: str, port: int, *, device: str = "telescope/0", client_id: int = 1,
                 timeout: float = 10.0) -> None:
        self.host = host
        self.port = port
        self.client_id = client_id
        self.timeout = timeout
        self._base = f"/api/v1/{device}/"
        self._host_header = f"Host: {host}:{port}\r\nUser-Agent: alpaca-zwo-bench\r\n"
        self._sock: socket.socket | None = None
        self._buf = bytearray()
        self._tid = 0
        self._last_use = 0.0
        self.latency = 0.0
        self.reconnects = 0

    # -- connection ----------------------------------------------------------------------------

    def _connect(self) -> socket.socket:
        sock = socket.create_connection((self.host, self.port), timeout=self.timeout)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._sock = sock
        self._buf.clear()
        return sock

    def close(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()

    # -- calls ---------------------------------------------------------------------------------

    def get(self, member: str, **params: object) -> Any:
        """GET a member and return its validated Value."""
        self._tid += 1
        tid = self._tid
        query = f"ClientID={self.client_id}&ClientTransactionID={tid}"
        if params:
            query += "&" + urlencode(params)
        request = f"GET {self._base}{member}?{query} HTTP/1.1\r\n{self._host_header}\r\n".encode()
        doc = self._call(request, tid, member)
        if "Value" not in doc:
            raise ReplyError(f"GET {member}: no Value in {doc!r:.200}")
        value = doc["Value"]
        expected = VALUE_TYPES.get(member)
        if expected is not None and (not isinstance(value, expected) or
                                     (bool not in expected and isinstance(value, bool))):
            raise ReplyError(f"GET {member}: Value {value!r:.80} is not {'/'.join(t.__name__ for t in expected)}")
        return value

    def put(self, member: str, **fields: object) -> Any:
        """PUT a member with form fields (names as Alpaca spells them); return Value if any."""
        self._tid += 1
        tid = self._tid
        form = {**fields, "ClientID": self.client_id, "ClientTransactionID": tid}
        body = urlencode(form).encode()
        request = (f"PUT {self._base}{member} HTTP/1.1\r\n{self._host_header}"
                   f"Content-Type: application/x-www-form-urlencoded\r\nContent-Length: {len(body)}\r\n\r\n"
                   ).encode() + body
        return self._call(request, tid, member).get("Value")

    def _call(self, request: bytes, tid: int, member: str) -> dict[str, Any]:
        started = time.perf_counter()
        sock = self._sock
        # A keep-alive connection idle for a while may have been closed by the server in the
        # meantime; then (and only then) one silent reconnect is what every HTTP client does.
        retry = sock is not None and started - self._last_use > 1.0
        try:
            if sock is None:
                sock = self._connect()
            try:
                sock.sendall(request)
                status, body = self._read_response(sock)
            except (_Closed, ConnectionResetError, BrokenPipeError):
                if not retry:
                    raise
                self.close()
                self.reconnects += 1
                started = time.perf_counter()
                sock = self._connect()
                sock.sendall(request)
                status, body = self._read_response(sock)
        except (OSError, _Closed) as exc:
            self.close()
            raise ReplyError(f"{member}: {type(exc).__name__}: {exc}") from None
        end = time.perf_counter()
        self.latency = end - started
        self._last_use = end
        if status != 200:
            raise ReplyError(f"{member}: HTTP {status}: {body[:200]!r}")
        try:
            doc = json.loads(body)
        except ValueError:
            raise ReplyError(f"{member}: reply is not JSON: {body[:200]!r}") from None
        if not isinstance(doc, dict):
            raise ReplyError(f"{member}: reply is not a JSON object: {body[:200]!r}")
        if doc.get("ErrorNumber") != 0:
            raise ReplyError(f"{member}: ErrorNumber {doc.get('ErrorNumber')!r} {doc.get('ErrorMessage')!r}")
        if doc.get("ClientTransactionID") != tid:
            raise ReplyError(f"{member}: ClientTransactionID {doc.get('ClientTransactionID')!r} != {tid}")
        return doc

    def _read_response(self, sock: socket.socket) -> tuple[int, bytes]:
        buf = self._buf
        while True:
            end = buf.find(b"\r\n\r\n")
            if end >= 0:
                break
            chunk = sock.recv(65536)
            if not chunk:
                if buf:
                    raise ConnectionResetError("connection closed inside a reply header")
                raise _Closed("connection closed by the server")
            buf += chunk
        head = bytes(buf[:end]).lower()
        try:
            status = int(head[9:12])
        except ValueError:
            raise ConnectionResetError(f"bad status line {head[:40]!r}") from None
        at = head.find(b"\r\ncontent-length:")
        if at < 0:
            raise ConnectionResetError("reply without Content-Length (chunked replies are not expected)")
        stop = head.find(b"\r\n", at + 2)
        length = int(head[at + 17: stop if stop >= 0 else len(head)])
        need = end + 4 + length
        while len(buf) < need:
            chunk = sock.recv(65536)
            if not chunk:
                raise ConnectionResetError("connection closed inside a reply body")
            buf += chunk
        body = bytes(buf[end + 4: need])
        del buf[:need]
        if b"\r\nconnection: close" in head:
            self.close()
        return status, body
