"""The link against the real emulator over TCP: reply kinds, matching under load, priority, faults."""

from __future__ import annotations

import random
import threading
import time
from collections.abc import Iterator

import pytest

from alpaca_zwo._exceptions import LinkError, LinkTimeout, MotionCancelled, MountReplyError, ProtocolError
from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.zwo import protocol as p
from alpaca_zwo.zwo import wire_values
from alpaca_zwo.zwo.link import Link, LinkState, Priority


@pytest.fixture
def model() -> MountModel:
    return MountModel(ScaledClock(), initialized=True)


def _serve(model: MountModel, baud: int = 0) -> EmulatorServer:
    return EmulatorServer(model, host="127.0.0.1", port=0, baud=baud).start()


@pytest.fixture
def emulator(model: MountModel) -> Iterator[EmulatorServer]:
    server = _serve(model)
    yield server
    server.stop()


@pytest.fixture
def link(emulator: EmulatorServer) -> Iterator[Link]:
    link = Link(f"socket://127.0.0.1:{emulator.port}", timeout=1.0, reconnect_delays=(0.1, 0.2, 0.5))
    link.open()
    link.expect_probe_reply("AM5")
    yield link
    link.close()


def test_every_reply_kind_is_read_to_its_end(link: Link) -> None:
    assert link.execute(p.query("GVP")) == "AM5"
    assert link.execute(p.set_target_ra(3.5)) is True  # bare '1'
    assert link.execute(p.set_target_dec(10.0)) is True
    assert link.execute(p.query("Q")) is None  # no reply at all, and nothing waited for
    with pytest.raises(MountReplyError) as info:  # at home, by the pole: 'e11#', read to its '#'
        link.execute(p.query("CM"))
    assert info.value.code == 11
    ra, dec = link.execute(p.query("GMEQ"))
    assert dec == 90.0 and 0.0 <= ra < 24.0
    assert link.execute(p.query("GU")).mode is wire_values.MountMode.EQUATORIAL


def test_a_refused_goto_reads_the_whole_error_and_stays_in_step(link: Link, model: MountModel) -> None:
    lst = model.clock_site.sidereal_time()
    link.execute(p.set_target_ra((lst + 12) % 24))  # opposite the meridian: below the horizon
    link.execute(p.set_target_dec(-60.0))
    with pytest.raises(MountReplyError) as info:
        link.execute(p.query("MS"))
    assert info.value.code == 5
    assert link.execute(p.query("GVP")) == "AM5"  # the '5#' did not stay behind


QUERIES = {
    "GVP": "AM5", "GLH": 90, "GRl": 1440, "GTa": wire_values.MeridianSettings(), "Ggr": 0.5, "GLC": False, "GLL": 0,
}


def test_32_threads_10000_exchanges_every_reply_matched(link: Link) -> None:
    """Commands and queries from many threads: each reply must be the one its own request asked for."""
    per_thread = 10_000 // 32 + 1
    mismatches: list[str] = []
    errors: list[BaseException] = []
    count = [0]
    lock = threading.Lock()

    def worker(seed: int) -> None:
        rng = random.Random(seed)
        codes = list(QUERIES)
        try:
            for _ in range(per_thread):
                roll = rng.random()
                if roll < 0.15:
                    assert link.execute(p.set_target_ra(rng.uniform(0, 23.9))) is True
                elif roll < 0.25:
                    link.execute(p.query("Q"), Priority.COMMAND)
                else:
                    code = rng.choice(codes)
                    priority = Priority.POLL if roll < 0.6 else Priority.COMMAND
                    value = link.execute(p.query(code), priority)
                    if value != QUERIES[code]:
                        with lock:
                            mismatches.append(f"{code} -> {value!r}")
                with lock:
                    count[0] += 1
        except BaseException as exc:  # collected and reported by the main thread
            errors.append(exc)

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(32)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors, errors[:3]
    assert count[0] >= 10_000
    assert mismatches == []


def test_commands_overtake_waiting_polls(model: MountModel) -> None:
    """With polls queued behind a busy line, a command goes out right after the exchange in flight."""
    server = _serve(model, baud=9600)
    link = Link(f"socket://127.0.0.1:{server.port}", timeout=2.0)
    link.open()
    try:
        started = threading.Event()
        stop = threading.Event()

        def poller() -> None:
            started.set()
            while not stop.is_set():
                link.execute(p.query("GMEQ"), Priority.POLL)

        pollers = [threading.Thread(target=poller) for _ in range(8)]
        for thread in pollers:
            thread.start()
        started.wait(2)
        link.execute(p.query("GVP"), Priority.POLL)  # make sure the queue is busy
        before = len(link.trace())
        link.execute(p.query("Q"), Priority.COMMAND)
        stop.set()
        for thread in pollers:
            thread.join()
        trace = link.trace()[before:]
        position = next(i for i, entry in enumerate(trace) if entry.request == ":Q#")
        # Only the exchange already on the wire (plus at most one that was granted as we queued) went first.
        assert position <= 1, [e.request for e in trace[: position + 1]]
    finally:
        link.close()
        server.stop()


def test_dropped_reply_times_out_then_the_link_is_back_in_step(link: Link, model: MountModel) -> None:
    model.faults.drop_replies(1)
    with pytest.raises(LinkTimeout):
        link.execute(p.query("GLH"))
    assert link.execute(p.query("GRl")) == 1440  # not the lost '90'
    assert link.counters.resyncs >= 1


def test_garbled_reply_never_becomes_data(link: Link, model: MountModel) -> None:
    outcomes = []
    for _ in range(20):
        model.faults.garble_replies(1)
        try:
            outcomes.append(link.execute(p.query("GLH")))
        except (ProtocolError, LinkTimeout):
            outcomes.append("error")
        assert link.execute(p.query("GRl")) == 1440
    assert all(o in (90, "error") for o in outcomes)


def test_stall_longer_than_the_timeout_never_shifts_replies(link: Link, model: MountModel) -> None:
    """A WiFi stall: the late reply to GLH must not be read as the answer to a later request."""
    model.faults.stall(2500)
    with pytest.raises(LinkTimeout):
        link.execute(p.query("GLH"))
    deadline = time.monotonic() + 10
    seen: list[object] = []
    while time.monotonic() < deadline:
        try:
            seen.append(link.execute(p.query("GRl")))
        except LinkTimeout:
            continue
        if len(seen) >= 3:
            break
    assert seen[-3:] == [1440, 1440, 1440]
    assert 90 not in seen


def _until_link_error(link: Link, timeout: float = 5.0) -> LinkError:
    """Exchange until the fault shows (the emulator applies it asynchronously); return the error."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            link.execute(p.query("GVP"))
        except LinkError as exc:
            return exc
    raise AssertionError("the link never noticed the fault")


def test_closed_connection_reconnects_and_bumps_the_generation(link: Link, model: MountModel) -> None:
    generation = link.generation
    model.faults.close_connections()
    _until_link_error(link)
    assert link.wait_connected(5.0)
    assert link.generation == generation + 1
    assert link.execute(p.query("GVP")) == "AM5"
    assert link.status.reconnects == 1


def test_outage_fails_fast_and_recovers(link: Link, model: MountModel) -> None:
    model.faults.outage(1.5)
    _until_link_error(link)
    began = time.monotonic()
    with pytest.raises(LinkError):
        link.execute(p.query("GVP"))
    assert time.monotonic() - began < 0.5  # no waiting on a dead line
    assert link.wait_connected(8.0)
    assert link.execute(p.query("GVP")) == "AM5"


def test_open_fails_clearly_when_nothing_listens() -> None:
    link = Link("socket://127.0.0.1:1", timeout=0.5)
    with pytest.raises(LinkError, match="cannot open"):
        link.open()
    assert link.status.state is LinkState.CLOSED


def test_trace_is_bounded_and_records_exchanges(emulator: EmulatorServer) -> None:
    link = Link(f"socket://127.0.0.1:{emulator.port}", trace_size=10)
    link.open()
    try:
        for _ in range(30):
            link.execute(p.query("GVP"))
        trace = link.trace()
        assert len(trace) == 10
        assert trace[-1].request == ":GVP#" and trace[-1].reply == "AM5#" and trace[-1].duration_ms >= 0
    finally:
        link.close()


def test_a_timed_move_starts_and_stops_on_an_idle_line(model: MountModel) -> None:
    """What starts a host-timed move (alt-az pulses) goes out only once the ``:Rv…#`` before it has
    left the line, and so does the stop that ends it, so both reach the mount their own bytes after
    the instant returned (the pulse measured write to write is the pulse the mount makes)."""
    server = _serve(model, baud=9600)
    link = Link(f"socket://127.0.0.1:{server.port}", baud=9600, timeout=1.0)
    link.open()
    try:
        speed, move, stop = (p.set_variable_speed(0.5), p.move(wire_values.Direction.NORTH),
                             p.stop_direction(wire_values.Direction.NORTH))
        before = time.monotonic()
        link.execute(speed)  # reply-less: back as soon as it is written
        started = link.send_on_idle_line(move)
        assert started - before >= len(speed.wire) * 10.0 / 9600
        stopped = link.send_urgent(stop, idle=True)
        assert stopped - started >= len(move.wire) * 10.0 / 9600
        assert link.execute(p.query("GVP")) == "AM5"  # the line is still in step
        assert model.snapshot()["moves_deg_s"] == [None, None]
    finally:
        link.close()
        server.stop()


def test_a_withdrawn_timed_move_is_never_written(link: Link, model: MountModel) -> None:
    with pytest.raises(MotionCancelled):
        link.send_on_idle_line(p.move(wire_values.Direction.EAST), guard=lambda: False)
    with pytest.raises(ValueError, match="has a reply"):
        link.send_on_idle_line(p.query("GVP"))
    assert model.snapshot()["moves_deg_s"] == [None, None]
    assert link.execute(p.query("GVP")) == "AM5"


def test_a_line_that_ignores_the_baud_piles_up_no_wait(link: Link) -> None:
    """The link assumes 9600 baud; this emulator answers at once (as USB CDC may). Each reply proves its
    request arrived, so hundreds of quick exchanges leave no modelled backlog for an idle-line write to
    wait out (before that rule, 300 polls here made a timed move's start wait about a second)."""
    for _ in range(300):
        link.execute(p.query("GVP"))
    before = time.monotonic()
    link.send_on_idle_line(p.stop_direction(wire_values.Direction.EAST))
    assert time.monotonic() - before < 0.1
