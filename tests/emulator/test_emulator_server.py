"""The server: several TCP connections on one mount, baud-rate pacing, counters, the pty."""

from __future__ import annotations

import os
import select
import socket
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from alpaca_zwo.emulator import EmulatorServer, ManualClock, MountModel
from alpaca_zwo.emulator import server as server_module
from alpaca_zwo.zwo import protocol
from tests.emulator.emuclient import MountClient, flags, initialize, target_at
from tests.support import wait_until


@pytest.fixture
def paced(model: MountModel) -> Iterator[EmulatorServer]:
    server = EmulatorServer(model, port=0, baud=9600).start()
    try:
        yield server
    finally:
        server.stop()


def test_several_connections_share_one_mount(
    connect: Callable[[], MountClient], model: MountModel, clock: ManualClock
) -> None:
    first, second, third = connect(), connect(), connect()
    initialize(first, clock)
    assert second.ask(":GC#") == first.ask(":GC#") != "01/01/00#"
    first.exact(protocol.set_target_ra(target_at(model, -2.0)).text)
    first.exact(":Sd+30*00:00#")
    assert second.ask(":Gr#") == first.ask(":Gr#")
    assert first.exact(":MS#") == "0"
    clock.advance(3.0)
    assert "N" not in flags(second)
    assert second.ask(":GR#") == third.ask(":GR#")
    assert third.exact(":MS#") == "e3#"
    third.send(":Q#")  # any connection can stop it
    clock.advance(3.0)  # the axes brake (the GOTO state lasts until they have)
    assert "N" in flags(first)


def test_each_connection_has_its_own_framer(connect: Callable[[], MountClient]) -> None:
    first, second = connect(), connect()
    first.write(":GV")  # half a command on one line...
    assert second.ask(":GVP#") == "AM5#"  # ...does not disturb the other
    assert first.exact("P#") == "AM5#"


def test_gr_exchange_takes_the_time_of_13_bytes_at_9600_baud(paced: EmulatorServer) -> None:
    client = MountClient(paced.port)
    try:
        expected = (4 + 9) * 10 / 9600  # 13.5 ms
        samples = []
        for _ in range(10):
            started = time.perf_counter()
            assert len(client.ask(":GR#")) == 9
            samples.append(time.perf_counter() - started)
        assert min(samples) >= expected * 0.95
        assert sorted(samples)[5] < expected + 0.05
        started = time.perf_counter()
        client.write(":GR#" * 20)
        client.read_until(lambda d: d.count(b"#") == 20)
        # Full duplex, like a UART: requests keep arriving while replies go out, but the 180 reply
        # bytes queue on the one outgoing wire.
        assert time.perf_counter() - started >= (4 + 20 * 9) * 10 / 9600 * 0.95
    finally:
        client.close()


def test_unpaced_server_is_much_faster(emu: EmulatorServer, mount: MountClient) -> None:
    started = time.perf_counter()
    for _ in range(20):
        mount.ask(":GR#")
    assert (time.perf_counter() - started) / 20 < (4 + 9) * 10 / 9600


def test_stats_count_bytes_and_exchanges(emu: EmulatorServer, connect: Callable[[], MountClient]) -> None:
    client = connect()
    client.ask(":GR#")  # 4 in, 9 out
    client.send(":Q#")  # 3 + sentinel 5 in, sentinel reply 9 out
    client.assert_silent(":XX#")  # 4 in, unknown: still an exchange, no reply
    deadline = time.monotonic() + 2.0
    while emu.stats()["total"]["exchanges"] < 4 and time.monotonic() < deadline:
        time.sleep(0.01)
    stats = emu.stats()
    (line,) = [entry for entry in stats["connections"] if entry["kind"] == "tcp"]
    assert line["bytes_in"] == 4 + 3 + 5 + 4
    assert line["bytes_out"] == 9 + 9
    assert line["exchanges"] == 4
    assert line["replies"] == 2
    assert stats["total"]["bytes_in"] == 16
    client.close()
    wait_until(lambda: emu.connection_count() == 0, 3.0, "the connections to close", interval=0.01)
    assert emu.stats()["total"]["bytes_in"] == 16  # totals survive the connection


def test_stop_closes_connections_and_is_idempotent(model: MountModel) -> None:
    with EmulatorServer(model, port=0, baud=0) as server:
        client = MountClient(server.port)
        assert client.ask(":GVP#") == "AM5#"
    client.sock.settimeout(2.0)
    assert client.sock.recv(10) == b""
    server.stop()
    client.close()


def test_pty_serves_pyserial_clients(model: MountModel, tmp_path: Path) -> None:
    serial = pytest.importorskip("serial")
    link = tmp_path / "ttyZWO"
    with EmulatorServer(model, port=0, baud=9600, pty=True, pty_link=str(link)) as server:
        assert server.pty_path is not None and server.pty_path.startswith("/dev/")
        assert os.path.realpath(link) == server.pty_path
        port = serial.Serial(server.pty_path, 9600, timeout=2.0)
        try:
            port.write(b":GVP#")
            assert port.read_until(b"#") == b"AM5#"
            port.write(b":SLE#")
            assert port.read(1) == b"1"
            port.write(b":Q#:GLC#")  # nothing for :Q#, then the query
            assert port.read_until(b"#") == b"1#"
            port.write(b":Rg0.30:GU#")
            assert port.read_until(b"#") == b"nNG000000000#"
            started = time.perf_counter()
            port.write(b":GR#")
            assert len(port.read_until(b"#")) == 9
            assert time.perf_counter() - started >= (4 + 9) * 10 / 9600 * 0.95  # paced like USB
        finally:
            port.close()
        old = server.pty_path
        server.faults.close_connections()
        new = server.wait_pty()
        assert new is not None
        wait_until(lambda: os.path.realpath(link) == server.pty_path, 3.0, "the link to follow the new pty",
                   interval=0.01)
        with serial.Serial(str(link), 9600, timeout=2.0) as again:
            again.write(b":GLC#")
            assert again.read_until(b"#") == b"1#"  # same mount, state kept
        assert old is not None


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="SO_TIMESTAMPNS is Linux's only")
def test_tcp_bytes_are_timed_by_their_arrival_not_by_when_the_reader_wakes() -> None:
    """The emulator acts on a command when its last byte would have arrived at the line's baud. A
    reader thread that wakes late (after a long quiet, and more so when a fast clock multiplies it, or
    on a machine that stalls it) must not move that instant: the kernel's receive stamp says when the
    bytes came. The read here is made late on purpose; the stamp must still say when they were sent."""
    listener = socket.create_server(("127.0.0.1", 0))
    client = socket.create_connection(listener.getsockname())
    accepted, _ = listener.accept()
    try:
        accepted.setsockopt(socket.SOL_SOCKET, server_module._SO_TIMESTAMPNS, 1)
        sent_wall, sent = time.time(), time.monotonic()
        client.sendall(b":Qe#")
        select.select([accepted], [], [], 5.0)
        time.sleep(0.05)  # the scenario: a reader that gets round to the bytes 50 ms (or more) after they came
        data, ancdata, _flags, _address = accepted.recvmsg(64, socket.CMSG_SPACE(16))
        read = time.monotonic()
        wall_stamp = server_module._kernel_stamp(ancdata)
        arrival = server_module._monotonic_arrival(wall_stamp)
        assert data == b":Qe#"
        assert wall_stamp is not None, f"no SO_TIMESTAMPNS stamp in {ancdata!r}"
        assert sent_wall - 0.001 <= wall_stamp <= time.time()
        # Converted to the monotonic clock, it is the arrival (right after the send), not the late read.
        assert sent - 0.001 <= arrival < read - 0.04
        assert arrival - sent < (read - sent) / 2
    finally:
        for sock in (client, accepted, listener):
            sock.close()


def test_a_receive_stamp_from_a_stepped_wall_clock_falls_back_to_the_reader_clock() -> None:
    """A wall clock stepped between arrival and read would move the arrival by the step: a stamp in the
    future, or older than any stall, is not used."""
    before = time.monotonic()
    for stepped in (time.time() + 5.0, time.time() - 3600.0, None):
        arrival = server_module._monotonic_arrival(stepped)
        assert before <= arrival <= time.monotonic()
    stall_wall, before = time.time() - 2.0, time.monotonic()
    late = server_module._monotonic_arrival(stall_wall)  # a 2 s stall: still the kernel's stamp
    after = time.monotonic()
    assert before - 2.0 - (after - before) - 0.001 <= late <= after - 2.0 + 0.001
