"""One byte pipe to the mount, done right.

The link owns the port (any pyserial URL: ``/dev/ttyACM0``, ``COM3``, ``socket://192.168.4.1:4030``,
``rfc2217://…``, ``loop://``). Exactly one request/reply exchange is on the wire at a time;
client commands jump ahead of background polls, so an abort waits for at most the exchange
already in flight. Replies are read by the kind the protocol table gives, never waiting for a
``#`` that will not come.

Keeping replies matched to requests is the link's first duty. After a timeout the mount may
still deliver the late reply (a WiFi stall), or never deliver it (a dropped reply); after junk
bytes the stream position is unknown. The link therefore marks itself *suspect* and, before the
next command, drains the input and proves it is back in step with a probe whose exact reply it
knows, repeated until nothing else arrives behind that reply. Only then does a new command go
out, so a stale reply can never be read as the answer to a later request.

An acknowledgement may also come late, or never: a real 1.8.8 mount busy with a GOTO left ``:Te#``
unanswered for the whole 1.5 s its driver waited (real-transcripts-1.8.8.md §2 item 8). When a
one-byte reply times out with nothing at all received, the link remembers that it is *owed* (for
``LATE_ACK_WINDOW_S``). A lone ``0``/``1``/``eN#`` found later -- drained before a command, ahead of
the resync probe's reply, or ahead of a query's reply that only parses without it -- is recorded as
that command's late reply and discarded, never read as the answer to the later command; the caller
of the timed-out command confirms it by reading the mount's state back. A timeout marks the line
suspect, never lost. What remains unknowable: a stray byte ahead of a query's reply that parses both
with and without it; the mount's two-digit fields make that impossible for the poll's own queries.

Stops have an urgent lane: :meth:`Link.send_urgent` writes a reply-less command (``:Q#``,
``:Qe#`` …) at once, between the bytes of whatever exchange is in flight, taking only the write
lock (held for the duration of one ``write``). A motion command may carry a *guard* that is
checked under that same lock right before its bytes go out, so a stop that bumped the guard's
generation either prevents the command or is written after it; it is never overtaken.

A reply that is not exactly one known form (a setter's byte with more bytes right behind it, a
GOTO's ``0`` followed by ``e5#``) is *ambiguous*: the link resynchronises and raises
:class:`~alpaca_zwo._exceptions.AmbiguousReply`, and the caller re-reads the mount's state
instead of assuming success.

What the link promises about a one-byte reply, and no more (the protocol has no checksum and no
framing for these replies, so nothing stronger is possible): every byte that reaches the host
within the *trailing window* after the link has read that byte -- ``TRAILING_QUIET_S`` (a GOTO's
``GOTO_QUIET_S``) plus three byte times at the link's baud -- makes the reply ambiguous. The
window is measured from the link's own read, which never comes before the byte arrived, so a
busy CPU only lengthens it; the window is always checked once more after it has ended, so an
oversleeping thread cannot skip its last moment. A byte arriving later than the window cannot be
told from noise ahead of the next reply: the next exchange reads it as an implausible or
multiple reply, marks the line suspect and resynchronises before anything else is sent.

When the port vanishes (USB unplugged, WiFi dropped, mount rebooted) the link reconnects in the
background with backoff and bumps :attr:`Link.generation`, which tells the mount layer that the
mount may have lost its time and site.
"""

from __future__ import annotations

import collections
import contextlib
import logging
import re
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum, IntEnum
from typing import Any

import serial

from .._exceptions import AmbiguousReply, LinkError, LinkTimeout, MotionCancelled, MountReplyError, ProtocolError
from . import protocol

log = logging.getLogger(__name__)


class Priority(IntEnum):
    """Who is waiting for the wire: commands from clients go before background polls."""

    COMMAND = 0
    POLL = 1


class LinkState(Enum):
    CONNECTING = "connecting"
    CONNECTED = "connected"
    RECONNECTING = "reconnecting"
    CLOSED = "closed"


@dataclass(frozen=True)
class LinkStatus:
    """What the setup page and DeviceState need to know about the link."""

    state: LinkState
    url: str
    since: float  # wall-clock time of the last state change
    last_error: str = ""
    reconnects: int = 0
    generation: int = 0

    @property
    def connected(self) -> bool:
        return self.state is LinkState.CONNECTED


@dataclass(frozen=True)
class TraceEntry:
    """One exchange (or link event) for diagnostics."""

    time: float  # wall clock
    request: str
    reply: str | None
    duration_ms: float
    note: str = ""


@dataclass
class LinkCounters:
    bytes_out: int = 0
    bytes_in: int = 0
    exchanges: int = 0
    timeouts: int = 0
    resyncs: int = 0
    drained_bytes: int = 0


class _Arbiter:
    """A FIFO lock with two priority classes: all waiting commands are served before any poll."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._busy = False
        self._queues: tuple[collections.deque[object], collections.deque[object]] = (
            collections.deque(),
            collections.deque(),
        )

    def _head(self) -> object | None:
        for queue in self._queues:
            if queue:
                return queue[0]
        return None

    def acquire(self, priority: Priority, timeout: float) -> None:
        ticket = object()
        deadline = time.monotonic() + timeout
        with self._cond:
            queue = self._queues[priority]
            queue.append(ticket)
            while self._busy or self._head() is not ticket:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    queue.remove(ticket)
                    self._cond.notify_all()
                    raise LinkTimeout(f"the mount line stayed busy for {timeout:.1f} s")
                self._cond.wait(remaining)
            queue.popleft()
            self._busy = True

    def release(self) -> None:
        with self._cond:
            self._busy = False
            self._cond.notify_all()


Opener = Callable[..., Any]


class Link:
    """The single owner of the mount port. Thread-safe; every method may be called from any thread."""

    #: The longest one wait for an idle line (48 bytes at 9600 baud): a bound, should the model be off.
    IDLE_WAIT_MAX_S = 0.05
    #: What an idle-line write waits beyond the modelled last byte: the transport's own latency
    #: (the bytes reach the line, or the emulator's reader, a fraction of a millisecond after the
    #: write), so a stop written right after a poll does not still queue behind it.
    IDLE_MARGIN_S = 0.001
    #: Silence that proves the input is empty: 48 bytes' time at 9600 baud.
    QUIET_S = 0.05
    #: How long a resynchronisation may keep draining a babbling line before giving up for now.
    DRAIN_LIMIT_S = 1.0
    READ_SLICE_S = 0.05
    PROBE_TIMEOUT_S = 1.0
    #: How long an acknowledgement that timed out may still arrive and be recognised as late: longer
    #: than the longest GOTO (a busy mount answers when its slew ends).
    LATE_ACK_WINDOW_S = 600.0
    #: After a one-byte reply, this much silence (plus 3 byte times) proves nothing else came with it;
    #: a GOTO (rare, and the one whose false success would move the mount) waits longer.
    TRAILING_QUIET_S = 0.003
    GOTO_QUIET_S = 0.03
    PROBE = protocol.query("GVP")

    def __init__(
        self,
        url: str,
        *,
        baud: int = 9600,
        timeout: float = 2.5,
        trace_size: int = 2000,
        opener: Opener = serial.serial_for_url,
        reconnect_delays: tuple[float, ...] = (0.2, 0.5, 1.0, 1.0, 2.0),
    ) -> None:
        self.url = url
        self.baud = baud
        self.timeout = timeout
        self._opener = opener
        self._reconnect_delays = reconnect_delays
        self._port: Any = None
        self._arbiter = _Arbiter()
        self._write_lock = threading.Lock()  # held only around one port.write (urgent lane + exchanges)
        #: When (time.monotonic) everything written so far has left the host at ``baud``: the line is
        #: idle after that (the ``idle`` writes wait for it). A reply proves its request arrived, so
        #: it ends the backlog (a line that ignores the baud would otherwise pile up a model backlog
        #: of seconds); an urgent write's own bytes still count (``_urgent_free``).
        self._tx_free = 0.0
        self._urgent_free = 0.0
        self._state_lock = threading.Lock()
        self._status = LinkStatus(LinkState.CLOSED, url, time.time())
        self._suspect = False
        self._probe_reply: str | None = None  # learnt on the first successful probe
        #: The one-byte reply still owed by a command that timed out with nothing received: (its
        #: request text, when it was sent); see the module docstring.
        self._owed: tuple[str, float] | None = None

        self._trace: collections.deque[TraceEntry] = collections.deque(maxlen=trace_size)
        self.counters = LinkCounters()
        self._reconnect_thread: threading.Thread | None = None
        self._closing = threading.Event()
        self._state_changed = threading.Condition(self._state_lock)

    # -- lifecycle ---------------------------------------------------------------------------

    @property
    def status(self) -> LinkStatus:
        return self._status

    @property
    def generation(self) -> int:
        """Bumped on every successful (re)connection: the mount behind it may have restarted."""
        return self._status.generation

    def open(self) -> None:
        """Open the port now; raise LinkError if the mount cannot be reached."""
        self._closing.clear()
        self._set_state(LinkState.CONNECTING)
        try:
            self._open_port()
        except LinkError as exc:
            self._set_state(LinkState.CLOSED, str(exc))
            raise
        self._set_state(LinkState.CONNECTED, bump=True)

    def close(self) -> None:
        self._closing.set()
        self._arbiter.acquire(Priority.COMMAND, self.timeout * 4)
        try:
            self._close_port()
        finally:
            self._arbiter.release()
        self._set_state(LinkState.CLOSED)
        thread = self._reconnect_thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5)

    def wait_connected(self, timeout: float) -> bool:
        """Block until the link is connected (True) or the timeout passes (False)."""
        deadline = time.monotonic() + timeout
        with self._state_changed:
            while self._status.state is not LinkState.CONNECTED:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._status.state is LinkState.CLOSED:
                    return False  # (it is not connected: the loop condition just said so)
                self._state_changed.wait(remaining)
        return True

    def expect_probe_reply(self, model: str) -> None:
        """Tell the link the mount's model name, the exact reply its resync probe must see."""
        self._probe_reply = f"{model}#"

    def trace(self) -> list[TraceEntry]:
        return list(self._trace)

    # -- exchanges ---------------------------------------------------------------------------

    def execute(self, req: protocol.Request, priority: Priority = Priority.COMMAND, *,
                guard: Callable[[], bool] | None = None, not_before: float | None = None) -> Any:
        """Send ``req`` and return its parsed reply (None for commands without a reply)."""
        return req.parse(self.exchange(req, priority, guard=guard, not_before=not_before))

    def exchange(self, req: protocol.Request, priority: Priority = Priority.COMMAND, *,
                 guard: Callable[[], bool] | None = None, not_before: float | None = None) -> str:
        """Send ``req`` and return its raw reply text ('' for commands without a reply).

        ``guard`` is called under the write lock right before the bytes go out; if it returns
        False nothing is sent and :class:`MotionCancelled` is raised. ``not_before`` (a
        ``time.monotonic()`` instant) holds the line and writes no earlier than that, so a timed
        command (the :Td# that freezes an alt/az landing) is not delayed by a poll starting first.
        """
        return self._exchange(req, priority, guard, not_before, idle=False)[0]

    def send_on_idle_line(self, req: protocol.Request, *, guard: Callable[[], bool] | None = None) -> float:
        """Send a reply-less command (as :meth:`exchange`) once nothing written before it is still
        on its way out, and return when it was written (``time.monotonic()``).

        For what starts a host-timed move: the move then begins its own few bytes after the
        returned instant, on a line paced at ``baud`` or on one that ignores the baud (USB CDC may),
        exactly as the stop that ends it (:meth:`send_urgent` with ``idle``) ends it. Waits at most
        the wire time of what is queued (9.4 ms for a ``:Rv…#`` at 9600 baud).
        """
        if req.kind is not protocol.ReplyKind.NONE:
            raise ValueError(f"{req.text} has a reply; send_on_idle_line() is for reply-less commands")
        return self._exchange(req, Priority.COMMAND, guard, None, idle=True)[1]

    def _exchange(self, req: protocol.Request, priority: Priority, guard: Callable[[], bool] | None,
                  not_before: float | None, idle: bool) -> tuple[str, float]:
        """The exchange: its reply text and when its request was written."""
        if self._status.state is not LinkState.CONNECTED:
            raise LinkError(f"mount link is {self._status.state.value}: {self._status.last_error or 'not open'}")
        self._arbiter.acquire(priority, self.timeout * 4)
        try:
            if self._port is None:
                raise LinkError(f"mount link is {self._status.state.value}")
            if self._suspect:
                self._resynchronise()
            elif self._port.in_waiting:
                # Bytes nobody asked for: stale or junk. Get back in step before sending.
                self._suspect = True
                self._resynchronise()
            if not_before is not None:
                delay = not_before - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            return self._exchange_locked(req, guard, idle)
        except (serial.SerialException, OSError) as exc:
            self._lost(exc)
            raise LinkError(f"mount link lost: {exc}") from exc
        finally:
            self._arbiter.release()

    def send_urgent(self, req: protocol.Request, *, idle: bool = False) -> float:
        """Write a reply-less command now, even while another exchange waits for its reply; return
        when it was written (``time.monotonic()``).

        Only for commands the mount never answers (stops): nothing is read, so no reply can be
        shifted. Takes only the write lock, never the line, so a stop waits for at most one
        ``write`` of a few bytes rather than a whole exchange. ``idle``: first let what is already
        on its way out leave (at most one request's wire time), so the returned instant is when the
        mount gets the stop less its own bytes, as for the move it ends (:meth:`send_on_idle_line`).
        """
        if req.kind is not protocol.ReplyKind.NONE:
            raise ValueError(f"{req.text} has a reply; only reply-less commands may use the urgent lane")
        started = time.monotonic()
        port = self._port
        if port is None or self._status.state is not LinkState.CONNECTED:
            raise LinkError(f"mount link is {self._status.state.value}: {self._status.last_error or 'not open'}")
        try:
            written = self._write(port, req.wire, None, idle)
        except (serial.SerialException, OSError) as exc:
            raise LinkError(f"mount link lost while stopping: {exc}") from exc
        if self.baud:
            self._urgent_free = written + len(req.wire) * 10.0 / self.baud
        self.counters.bytes_out += len(req.wire)
        self.counters.exchanges += 1
        self._record(req.text, "", started, "urgent")
        return written

    def _write(self, port: Any, wire: bytes, guard: Callable[[], bool] | None, idle: bool) -> float:
        """Write under the write lock (checking ``guard`` right before); return when it was written.

        ``idle``: not before everything written earlier has left the host at ``baud`` (the wait is
        outside the lock, so a stop is never held up by it; a write that slipped in meanwhile is
        waited out too, a bounded number of times). The wait is at most the bytes written since the
        last reply: a few requests' worth, milliseconds."""
        for attempt in range(8):
            if idle:
                delay = self._tx_free + self.IDLE_MARGIN_S - time.monotonic()
                if delay > 0:
                    time.sleep(min(delay, self.IDLE_WAIT_MAX_S))
            with self._write_lock:
                now = time.monotonic()
                if idle and self._tx_free + self.IDLE_MARGIN_S > now and attempt < 7:
                    continue  # another write got in first
                if guard is not None and not guard():
                    raise MotionCancelled(f"{wire.decode('latin-1')} not sent: a stop came first")
                port.write(wire)
                if self.baud:
                    self._tx_free = max(now, self._tx_free) + len(wire) * 10.0 / self.baud
                return time.monotonic()
        raise AssertionError("unreachable")

    def _exchange_locked(self, req: protocol.Request, guard: Callable[[], bool] | None = None,
                         idle: bool = False) -> tuple[str, float]:
        started = time.monotonic()
        wire = req.wire
        written = self._write(self._port, wire, guard, idle)
        self.counters.bytes_out += len(wire)
        self.counters.exchanges += 1
        try:
            reply = self._read_reply(req.kind, started + self.timeout)
        except LinkTimeout as exc:
            self.counters.timeouts += 1
            self._suspect = True
            if isinstance(exc, _NothingArrived) and req.kind in (protocol.ReplyKind.CHAR, protocol.ReplyKind.GOTO):
                self._owed = (req.text, started)  # a busy mount may still send it (module docstring)
            self._record(req.text, None, started, f"timeout: {exc}")
            raise LinkTimeout(f"no complete reply to {req.text} within {self.timeout:.1f} s") from exc
        if req.kind is protocol.ReplyKind.TEXT and self._owed is not None:
            reply = self._without_late_ack(req, reply)
        quiet = self.GOTO_QUIET_S if req.kind is protocol.ReplyKind.GOTO else self.TRAILING_QUIET_S
        if req.kind in (protocol.ReplyKind.CHAR, protocol.ReplyKind.GOTO) and self._trailing_bytes(quiet):
            # A one-byte answer with more right behind it ('0' then 'e5#'): which byte was the
            # reply is unknowable, so it is neither success nor failure.
            self._suspect = True
            self._record(req.text, reply, started, "ambiguous: more bytes followed the reply")
            raise AmbiguousReply(f"ambiguous reply to {req.text}: {reply!r} followed by more bytes")
        self._record(req.text, reply, started)
        if req.kind is not protocol.ReplyKind.NONE:
            with self._write_lock:  # the mount has the request: nothing of it is still on the wire
                self._tx_free = min(self._tx_free, max(time.monotonic() - self.IDLE_MARGIN_S, self._urgent_free))
        if not _plausible(req, reply):
            self._suspect = True
            raise ProtocolError(f"implausible reply {reply!r} to {req.text}")
        return reply, written

    def _trailing_bytes(self, quiet_s: float) -> bool:
        """Whether bytes arrive right behind a reply: the trailing window of the module docstring.

        The input is looked at once more after the window has ended, however late this thread
        wakes, so a byte that arrived inside the window is never missed under CPU load."""
        port = self._port
        byte_time = 10.0 / self.baud if self.baud else 0.0
        deadline = time.monotonic() + quiet_s + 3 * byte_time
        while True:
            if port.in_waiting:
                return True
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            time.sleep(min(0.0005, remaining))

    def _settle_owed(self, stale: bytes) -> bool:
        """Whether ``stale`` (bytes found where no reply was expected) is the acknowledgement a timed-out
        command still owed; if so it is recorded as that command's late reply, and nothing is owed."""
        owed = self._owed
        if owed is None:
            return False
        request, since = owed
        if time.monotonic() - since > self.LATE_ACK_WINDOW_S:
            self._owed = None  # too late to tell from noise: the shape checks treat it as such
            return False
        text = stale.decode("latin-1")
        if not _ACK_RE.fullmatch(text):
            return False
        self._owed = None
        log.info("late acknowledgement %r of %s, %.1f s after it was sent", text, request, time.monotonic() - since)
        self._record(request, text, since, "late acknowledgement: arrived after its timeout, not taken as a reply")
        return True

    def _without_late_ack(self, req: protocol.Request, reply: str) -> str:
        """A query's reply with the owed acknowledgement in front of it (the mount sent it just before
        answering): the reply without it, when only that parses. Otherwise the reply as it came."""
        if reply[:1] in ("0", "1") and not _parses(req, reply) and _parses(req, reply[1:]) \
                and self._settle_owed(reply[:1].encode("latin-1")):
            return reply[1:]
        return reply

    def _read_reply(self, kind: protocol.ReplyKind, deadline: float) -> str:
        if kind is protocol.ReplyKind.NONE:
            return ""
        port = self._port
        data = bytearray()
        while not protocol.reply_complete(kind, bytes(data)):
            if time.monotonic() >= deadline:
                if not data:
                    raise _NothingArrived("no reply at all")
                raise LinkTimeout(f"partial reply {bytes(data)!r}")
            # One byte at a time for bare-character replies so nothing behind them is consumed.
            want = 1 if kind is not protocol.ReplyKind.TEXT and not data else max(1, port.in_waiting)
            chunk = port.read(want)
            if chunk:
                data += chunk
                self.counters.bytes_in += len(chunk)
                if len(data) > 128:
                    self._suspect = True
                    raise ProtocolError(f"runaway reply {bytes(data[:32])!r}…")
        text = data.decode("latin-1")
        if kind is protocol.ReplyKind.TEXT and not text.endswith("#"):
            raise ProtocolError(f"unterminated reply {text!r}")
        if text.count("#") > 1 or (kind is protocol.ReplyKind.TEXT and text.index("#") != len(text) - 1):
            # More than one reply's worth: something stale was already queued.
            self._suspect = True
            raise ProtocolError(f"reply {text!r} holds more than one answer")
        return text

    # -- resynchronisation -------------------------------------------------------------------

    def _drain(self, quiet_s: float) -> int:
        """Read and discard until the line has been silent for ``quiet_s``; bounded in time. Returns how
        many bytes went; an owed acknowledgement among them is recorded as late (:meth:`_settle_owed`)."""
        port = self._port
        drained = bytearray()
        give_up = time.monotonic() + self.DRAIN_LIMIT_S
        quiet_until = time.monotonic() + quiet_s
        while time.monotonic() < quiet_until:
            chunk = port.read(max(1, port.in_waiting))
            if chunk:
                drained += chunk
                quiet_until = time.monotonic() + quiet_s
                if time.monotonic() > give_up:
                    break
        self.counters.drained_bytes += len(drained)
        if drained:
            self._settle_owed(bytes(drained))
        return len(drained)

    def _resynchronise(self) -> None:
        """Prove the stream is in step again, or raise LinkTimeout without sending the command.

        Drain; send the probe; read up to its '#'. A reply that is not exactly the probe's (a
        stale answer to an earlier request) or anything arriving after it means the line still
        held old replies, so go round again. Stale replies arrive in order, ahead of the probe's.
        """
        self.counters.resyncs += 1
        started = time.monotonic()
        for _attempt in range(6):
            drained = self._drain(self.QUIET_S)
            self._write(self._port, self.PROBE.wire, None, False)
            self.counters.bytes_out += len(self.PROBE.wire)
            try:
                # The probe's reply is ~7 ms away even at 9600 baud, so it gets a short timeout: a
                # client command waiting behind a resync in a stalled line then still answers in
                # well under the 5 s clients allow (one exchange in flight + one probe).
                reply = self._read_probe(time.monotonic() + min(self.PROBE_TIMEOUT_S, self.timeout))
            except LinkTimeout:
                self._record(self.PROBE.text, None, started, f"resync: probe timed out (drained {drained} B)")
                raise LinkTimeout("the mount did not answer the resynchronisation probe") from None
            if self._drain(self.QUIET_S) == 0 and reply is not None:
                self._suspect = False
                self._record(self.PROBE.text, reply, started, f"resync: back in step (drained {drained} B)")
                return
        self._record(self.PROBE.text, None, started, "resync: line still babbling")
        raise LinkTimeout("could not resynchronise with the mount")

    def _read_probe(self, deadline: float) -> str | None:
        """Read replies up to the probe's own; None if what ended with '#' was not the probe's."""
        data = bytearray()
        port = self._port
        while time.monotonic() < deadline:
            chunk = port.read(1)
            if not chunk:
                continue
            self.counters.bytes_in += 1
            data += chunk
            if chunk == b"#":
                text = data.decode("latin-1")
                if self._probe_reply is None:
                    if protocol.MODEL_NAME_RE.fullmatch(text[:-1]):
                        self._probe_reply = text  # the first probe teaches us the model name
                        return text
                elif text.endswith(self._probe_reply):
                    # Ours, behind bytes with no '#' of their own (a late acknowledgement, junk): the
                    # drain after the probe still proves nothing else follows.
                    self._settle_owed(bytes(data[: len(data) - len(self._probe_reply)]))
                    return self._probe_reply
                self._settle_owed(bytes(data))  # a stale reply (a late 'eN#' is recorded as such)
                data.clear()  # keep reading for ours
        raise LinkTimeout("probe reply did not arrive")

    # -- connection management ---------------------------------------------------------------

    def _open_port(self) -> None:
        try:
            port = self._opener(self.url, baudrate=self.baud, timeout=self.READ_SLICE_S, write_timeout=self.timeout)
        except (serial.SerialException, OSError, ValueError) as exc:
            raise LinkError(f"cannot open {self.url}: {exc}") from exc
        sock = getattr(port, "_socket", None)
        if isinstance(sock, socket.socket):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._port = port
        self._suspect = True  # whatever was buffered before we came is not ours

    def _close_port(self) -> None:
        port, self._port = self._port, None
        if port is not None:
            with contextlib.suppress(serial.SerialException, OSError):
                port.close()

    def _lost(self, exc: BaseException) -> None:
        """Called with the arbiter held when the port failed: close it and start reconnecting."""
        self._close_port()
        if self._closing.is_set():
            return
        log.warning("mount link %s lost: %s; reconnecting", self.url, exc)
        self._record("", None, time.monotonic(), f"link lost: {exc}")
        self._set_state(LinkState.RECONNECTING, str(exc))
        thread = threading.Thread(target=self._reconnect_loop, name="link-reconnect", daemon=True)
        self._reconnect_thread = thread
        thread.start()

    def _reconnect_loop(self) -> None:
        attempt = 0
        while not self._closing.is_set():
            delay = self._reconnect_delays[min(attempt, len(self._reconnect_delays) - 1)]
            if self._closing.wait(delay):
                return
            attempt += 1
            try:
                self._arbiter.acquire(Priority.COMMAND, self.timeout * 4)
            except LinkTimeout:
                continue
            try:
                if self._closing.is_set():
                    return
                self._open_port()
                # A port that opens is not yet a mount that answers (a WiFi AP can accept and then
                # reset): only a correct probe reply counts as reconnected.
                self._resynchronise()
            except (LinkError, serial.SerialException, OSError) as exc:
                self._close_port()
                self._set_state(LinkState.RECONNECTING, str(exc))
                continue
            finally:
                self._arbiter.release()
            log.info("mount link %s reconnected after %d attempt(s)", self.url, attempt)
            self._record("", None, time.monotonic(), "link reconnected")
            self._set_state(LinkState.CONNECTED, bump=True, reconnected=True)
            return

    def _set_state(self, state: LinkState, error: str = "", *, bump: bool = False, reconnected: bool = False) -> None:
        with self._state_changed:
            old = self._status
            self._status = LinkStatus(
                state,
                self.url,
                time.time() if state is not old.state else old.since,
                error if error or state is not LinkState.CONNECTED else "",
                old.reconnects + (1 if reconnected else 0),
                old.generation + (1 if bump else 0),
            )
            self._state_changed.notify_all()

    def _record(self, request: str, reply: str | None, started: float, note: str = "") -> None:
        self._trace.append(
            TraceEntry(time.time(), request, reply, (time.monotonic() - started) * 1000.0, note)
        )




class _NothingArrived(LinkTimeout):
    """Not one byte of the reply came in time (a busy mount's late or missing acknowledgement)."""


#: A lone acknowledgement as a late one arrives: a bare ``0``/``1`` or an ``eN#`` refusal.
_ACK_RE = re.compile(r"[01]|e\d{1,2}#")


def _parses(req: protocol.Request, reply: str) -> bool:
    """Whether ``reply`` reads as an answer to ``req`` (a refusal counts: it is an answer)."""
    try:
        req.parse(reply)
    except MountReplyError:
        return True
    except (ProtocolError, ValueError, IndexError):
        return False
    return True


def _plausible(req: protocol.Request, reply: str) -> bool:
    """A cheap shape check so junk in place of a reply is caught at the link, not parsed as data."""
    kind = req.kind
    if kind is protocol.ReplyKind.NONE:
        return reply == ""
    if kind is protocol.ReplyKind.CHAR:
        return reply in ("0", "1") or reply.startswith("e") or (req.command.code == "Sp01" and reply.isdigit())
    if kind is protocol.ReplyKind.GOTO:
        return reply == "0" or reply.startswith("e")
    return all(" " <= ch <= "~" or ch in "°ß\xdf" for ch in reply)
