"""Property test: junk on the line never makes the link misattribute a reply.

A small TCP mount answers with the real emulator's responder but injects hypothesis-chosen junk
before (or instead of) the reply to one request. The link must either return that request's true
value or raise one of our errors, and the next request must get its own true value: one bad reply
never shifts the ones after it.

The junk always holds at least one byte that cannot occur in these replies. Junk made only of
reply characters (a stray ``1`` before ``90#``) is indistinguishable from data: the ZWO protocol
has no checksum, so no reader can catch it, and this test does not pretend otherwise.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from alpaca_zwo._exceptions import LinkTimeout, MountReplyError, ProtocolError
from alpaca_zwo.emulator import ManualClock, ModelResponder, MountModel
from alpaca_zwo.zwo import protocol as p
from alpaca_zwo.zwo import request_framer
from alpaca_zwo.zwo.link import Link
from tests.support.wait import wait_until


class JunkMount:
    """One TCP connection's worth of mount that puts ``junk`` in front of the next reply (or instead).

    With ``gap_s`` the junk and the reply leave as two writes that far apart, as a noisy line
    delivers them; without it, as one.
    """

    gap_s = 0.0

    def __init__(self) -> None:
        self.responder = ModelResponder(MountModel(ManualClock(), initialized=True))
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.junk = b""
        self.replace = False
        self.lock = threading.Lock()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def arm(self, junk: bytes, replace: bool) -> None:
        with self.lock:
            self.junk, self.replace = junk, replace

    def _serve(self) -> None:
        while True:
            try:
                conn, _ = self.listener.accept()
            except OSError:
                return
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # a serial line has no Nagle delay
            framer = request_framer.RequestFramer()
            with conn:
                while True:
                    try:
                        data = conn.recv(4096)
                    except OSError:
                        break
                    if not data:
                        break
                    for body in framer.feed(data):
                        reply = self.responder.handle(body)
                        with self.lock:
                            junk, replace = self.junk, self.replace
                            self.junk, self.replace = b"", False  # one reply is mangled, not all after it
                        answer = b"" if replace or reply is None else reply.encode("latin-1")
                        if junk and answer and self.gap_s:
                            conn.sendall(junk)
                            time.sleep(self.gap_s)  # the line's own timing, not a wait for anything
                            conn.sendall(answer)
                        elif junk or answer:
                            conn.sendall(junk + answer)

    def close(self) -> None:
        self.listener.close()


@pytest.fixture(scope="module")
def junk_link() -> Iterator[tuple[Link, JunkMount]]:
    mount = JunkMount()
    link = Link(f"socket://127.0.0.1:{mount.port}", timeout=0.25)
    link.open()
    link.expect_probe_reply("AM5")
    yield link, mount
    link.close()
    mount.close()


EXPECTED = {"GLH": 90, "GRl": 1440, "GVP": "AM5", "GLL": 0}
#: Bytes none of the replies above can contain (control bytes, high bytes, symbols).
FOREIGN = bytes([*range(0, 32), *range(127, 256), *b"!$%&'()*+,-./;<=>?@[]^_`{|}~"])
JUNK = st.binary(min_size=1, max_size=24).filter(lambda b: any(c in FOREIGN for c in b))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(junk=JUNK, replace=st.booleans(),
       first=st.sampled_from(sorted(EXPECTED)), second=st.sampled_from(sorted(EXPECTED)))
def test_junk_never_shifts_replies(junk_link: tuple[Link, JunkMount], junk: bytes, replace: bool, first: str,
                                   second: str) -> None:
    link, mount = junk_link
    mount.arm(junk, replace)
    try:
        value = link.execute(p.query(first))
    except (ProtocolError, LinkTimeout, MountReplyError):
        pass  # refusing the mangled exchange is fine
    else:
        assert value == EXPECTED[first], f"junk {junk!r} produced {value!r} for :{first}#"
    for _ in range(3):  # the probe itself may meet leftovers; the next clean exchange must be exact
        try:
            assert link.execute(p.query(second)) == EXPECTED[second]
            return
        except (ProtocolError, LinkTimeout):
            continue
    pytest.fail(f"the link never got back in step after junk {junk!r}")


# -- replies that are not exactly one known form are never success ---------------------------------

#: Commands whose success is a single byte, set up so that the mount refuses them: a GOTO below the
#: horizon (e5#) and a target Dec out of range ('0'). Junk in front of a refusal must never read
#: as success, however it is split on the wire.
REFUSED = {"MS": p.query("MS"), "Sd": p.request("Sd", "+91*00:00")}
#: Junk made of the bytes that open a reply ('0', '1', 'e'), digits and noise, never ':' or '#'.
PREFIX = st.binary(min_size=1, max_size=6).filter(lambda b: b":" not in b and b"#" not in b) | st.sampled_from(
    [b"0", b"1", b"e", b"00", b"10", b"1e"])


class TimedLine:
    """A serial line whose bytes become readable at instants fixed when the request is written.

    The mount behind it is the real emulator's responder. With ``junk`` armed, the next reply is
    preceded by those bytes, readable at once, and the reply itself becomes readable ``gap_s``
    later. Because the instants are fixed on the monotonic clock at the write, however late either
    thread runs does not change when a byte arrives: the test judges the link's promise (module
    docstring of ``alpaca_zwo.zwo.link``), not the scheduler. The link reads it through the
    methods it uses on any pyserial port.
    """

    def __init__(self, responder: ModelResponder) -> None:
        self.responder = responder
        self.timeout = 0.05
        self.junk = b""
        self.gap_s = 0.0
        self._framer = request_framer.RequestFramer()
        self._bytes: list[tuple[float, int]] = []  # (readable from, byte), in line order
        self._cond = threading.Condition()

    def arm(self, junk: bytes, gap_s: float) -> None:
        with self._cond:
            self.junk, self.gap_s = junk, gap_s

    def write(self, data: bytes) -> int:
        now = time.monotonic()
        with self._cond:
            for body in self._framer.feed(data):
                reply = self.responder.handle(body)
                answer = b"" if reply is None else reply.encode("latin-1")
                junk, self.junk = self.junk, b""  # one reply is preceded, not all after it
                later = now + (self.gap_s if junk and answer else 0.0)
                self._append(now, junk)
                self._append(later, answer)
            self._cond.notify_all()
        return len(data)

    def _append(self, at: float, data: bytes) -> None:
        last = self._bytes[-1][0] if self._bytes else at
        self._bytes.extend((max(at, last), b) for b in data)  # a line delivers in order

    def _readable(self, now: float) -> int:
        return sum(1 for at, _ in self._bytes if at <= now)

    @property
    def in_waiting(self) -> int:
        with self._cond:
            return self._readable(time.monotonic())

    def read(self, size: int = 1) -> bytes:
        give_up = time.monotonic() + self.timeout
        with self._cond:
            while True:
                now = time.monotonic()
                ready = min(size, self._readable(now))
                if ready:
                    out = bytes(b for _, b in self._bytes[:ready])
                    del self._bytes[:ready]
                    return out
                if now >= give_up:
                    return b""
                upcoming = [at for at, _ in self._bytes[:1]]
                self._cond.wait(min([give_up - now, *(at - now for at in upcoming)]))

    def close(self) -> None:
        pass


@pytest.fixture(scope="module")
def split_link() -> Iterator[tuple[Link, TimedLine]]:
    model = MountModel(ManualClock(), initialized=True)
    model.clock_site.set_latitude(51.5)
    model.clock_site.set_longitude(0.0)
    line = TimedLine(ModelResponder(model))
    link = Link("timed://", timeout=0.25, opener=lambda _url, **_kw: line)
    link.open()
    link.expect_probe_reply("AM5")
    # Target below the horizon: every :MS# is refused with e5#.
    lst = model.clock_site.sidereal_time()
    link.execute(p.set_target_ra((lst + 12.0) % 24.0))
    link.execute(p.set_target_dec(-60.0))
    yield link, line
    link.close()


#: Gaps between the junk and the refusal, all inside the trailing window the link promises for a
#: one-byte reply at its 9600 baud (3 ms + 3 byte times = 6.1 ms; a GOTO's 30 ms + 3 byte times).
GAPS_MS = [0.0, 0.5, 2.0, 5.0]


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(junk=PREFIX, which=st.sampled_from(sorted(REFUSED)), gap_ms=st.sampled_from(GAPS_MS))
def test_junk_before_a_refusal_is_never_success(split_link: tuple[Link, TimedLine], junk: bytes, which: str,
                                                gap_ms: float) -> None:
    """Junk, then within the trailing window the mount's refusal: never read as success."""
    link, line = split_link
    assert gap_ms / 1000.0 < Link.TRAILING_QUIET_S + 3 * 10.0 / link.baud
    line.arm(junk, gap_ms / 1000.0)
    try:
        value = link.execute(REFUSED[which])
    except (ProtocolError, LinkTimeout, MountReplyError):
        pass  # ambiguous, garbled or refused: all honest
    else:
        pytest.fail(f"junk {junk!r} + refusal of :{which}# {gap_ms} ms later was taken as success ({value!r})")
    for _ in range(3):  # and the line gets back in step
        try:
            assert link.execute(p.query("GVP")) == "AM5"
            return
        except (ProtocolError, LinkTimeout):
            continue
    pytest.fail(f"the link never got back in step after junk {junk!r}")


def test_a_byte_after_the_window_is_caught_by_the_next_exchange(split_link: tuple[Link, TimedLine]) -> None:
    """Past the window the link cannot tell (the promise's other half): the late refusal is not lost,
    it makes the next exchange resynchronise, and that exchange still gets its own reply."""
    link, line = split_link
    line.arm(b"1", 0.2)  # the refusal '0' comes 200 ms after the junk '1'
    assert link.execute(REFUSED["Sd"]) is True  # '1' alone, then silence: indistinguishable from success
    resyncs = link.counters.resyncs
    wait_until(lambda: line.in_waiting > 0, timeout=2.0, what="the late refusal on the line")
    assert link.execute(p.query("GVP")) == "AM5"
    assert link.execute(p.query("GLH")) == 90
    assert link.counters.resyncs > resyncs


@given(text=st.text(min_size=0, max_size=8))
def test_reply_parser_takes_only_exact_success_forms(text: str) -> None:
    """The parser's side of the same rule: only the exact bare '0' (GOTO) or '1' (setter) is success."""
    for req, success in ((p.query("MS"), "0"), (p.request("Sd", "+10*00:00"), "1")):
        try:
            result = req.parse(text)
        except (ProtocolError, MountReplyError):
            continue
        assert text == success and result is True, f"{text!r} read as success for {req.text}"
