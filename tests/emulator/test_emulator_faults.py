"""Every fault switch, observed over real TCP: dropped, garbled and stalled replies, closed
connections, an outage and a mount reboot. Faults must never take the server down."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable

import pytest

from alpaca_zwo.emulator import EmulatorServer, ManualClock, MountModel
from tests.emulator.emuclient import MountClient, flags, initialize
from tests.support import wait_until


def _connection_is_dropped(client: MountClient, timeout: float = 3.0) -> bool:
    """True once the server has closed (or reset) this connection."""
    client.sock.settimeout(timeout)
    try:
        return client.sock.recv(100) == b""
    except ConnectionResetError:
        return True
    except TimeoutError:
        return False


def _connect_is_refused(port: int) -> bool:
    """A new connection is reset or closed by the server without a word."""
    try:
        sock = socket.create_connection(("127.0.0.1", port), timeout=2.0)
    except OSError:
        return True
    try:
        sock.sendall(b":GVP#")
        sock.settimeout(2.0)
        return sock.recv(100) == b""
    except (ConnectionResetError, BrokenPipeError):
        return True
    except TimeoutError:
        return False
    finally:
        sock.close()


def test_dropped_reply_is_swallowed_but_the_command_acts(emu: EmulatorServer, mount: MountClient) -> None:
    emu.faults.drop_replies(1)
    mount.assert_silent(":SLE#")
    assert mount.ask(":GLC#") == "1#"  # it was applied, and only one reply was eaten
    emu.faults.drop_replies(2)
    mount.assert_silent(":GVP#:GV#")
    assert mount.ask(":GVP#") == "AM5#"
    assert emu.stats()["faults"]["dropped"] == 3


def test_garbled_reply_is_preceded_by_junk(emu: EmulatorServer, mount: MountClient) -> None:
    emu.faults.garble_replies(1)
    mount.write(":GVP#")
    data = mount.read_until(lambda d: d.endswith(b"#"))
    assert data != b"AM5#" and data.endswith(b"AM5#")
    assert 1 <= len(data) - 4 <= 4 and b":" not in data
    assert mount.ask(":GVP#") == "AM5#"


def test_garbled_reply_can_replace_the_reply(emu: EmulatorServer, mount: MountClient) -> None:
    emu.faults.garble_replies(1, replace=True)
    mount.write(":GVP#")
    mount.sock.settimeout(1.0)
    junk = mount.sock.recv(100)
    assert junk and b"AM5" not in junk and b"#" not in junk
    assert mount.ask(":GV#") == "1.9.2#"


def test_stall_delays_replies_then_delivery_resumes(emu: EmulatorServer, mount: MountClient) -> None:
    emu.faults.stall(400)
    started = time.monotonic()
    assert mount.ask(":GVP#") == "AM5#"
    assert time.monotonic() - started >= 0.38
    started = time.monotonic()
    assert mount.ask(":GVP#") == "AM5#"
    assert time.monotonic() - started < 0.2


def test_close_connections_drops_every_client(emu: EmulatorServer, connect: Callable[[], MountClient]) -> None:
    first, second = connect(), connect()
    assert first.ask(":GVP#") == second.ask(":GVP#") == "AM5#"
    emu.faults.close_connections()
    assert _connection_is_dropped(first)
    assert _connection_is_dropped(second)
    assert connect().ask(":GVP#") == "AM5#"  # the mount itself is fine


def test_close_also_drops_connections_not_yet_accepted(emu: EmulatorServer) -> None:
    """A client whose handshake just completed (still in the listen backlog) is dropped too."""
    for _ in range(20):
        sock = socket.create_connection(("127.0.0.1", emu.port), timeout=3.0)
        try:
            emu.faults.close_connections()
            sock.settimeout(3.0)
            try:
                sock.sendall(b":GVP#")
                assert sock.recv(100) == b""
            except (ConnectionResetError, BrokenPipeError):
                pass
        finally:
            sock.close()


def test_outage_refuses_new_connections_for_its_duration(
    emu: EmulatorServer, mount: MountClient, connect: Callable[[], MountClient]
) -> None:
    emu.faults.outage(0.6)
    assert _connection_is_dropped(mount)
    assert _connect_is_refused(emu.port)
    wait_until(lambda: not emu.faults.refusing(), 5.0, "the outage to run out", interval=0.02)
    assert connect().ask(":GVP#") == "AM5#"
    assert emu.stats()["refused"] >= 1


def test_reboot_returns_the_power_up_state_and_keeps_flash(
    emu: EmulatorServer,
    mount: MountClient,
    model: MountModel,
    clock: ManualClock,
    connect: Callable[[], MountClient],
) -> None:
    initialize(mount, clock)
    assert mount.exact(":SLL10#") == "1"
    assert mount.exact(":Te#") == "1"
    emu.faults.reboot(0.5)
    assert _connection_is_dropped(mount)
    assert _connect_is_refused(emu.port)
    wait_until(lambda: not emu.faults.refusing(), 5.0, "the outage to run out", interval=0.02)
    client = connect()
    assert client.ask(":GC#") == "01/01/00#"
    assert client.ask(":GL#") == "00:00:00#"
    assert flags(client) == "nNG"
    assert client.ask(":Gm#") == "N#"
    assert client.ask(":GLL#") == "10#"
    assert model.power_ups == 2


def test_faults_under_load_never_kill_the_server(emu: EmulatorServer, connect: Callable[[], MountClient]) -> None:
    stop = threading.Event()
    errors: list[BaseException] = []

    def hammer() -> None:
        while not stop.is_set():
            try:
                with socket.create_connection(("127.0.0.1", emu.port), timeout=1.0) as sock:
                    for _ in range(20):
                        sock.sendall(b":GR#:GD#:GU#:Mgn0010#:Q#")
                        sock.recv(4096)
            except OSError:
                continue
            except BaseException as exc:  # pragma: no cover - reported below
                errors.append(exc)
                return

    threads = [threading.Thread(target=hammer) for _ in range(3)]
    for thread in threads:
        thread.start()
    try:
        for _ in range(5):
            emu.faults.garble_replies(3)
            emu.faults.drop_replies(2)
            emu.faults.stall(20)
            emu.faults.close_connections()
        emu.faults.outage(0.1)
        wait_until(lambda: not emu.faults.refusing(), 5.0, "the outage to run out", interval=0.02)
    finally:
        stop.set()
        for thread in threads:
            thread.join(5.0)
    assert not errors
    emu.faults.clear()
    assert connect().ask(":GVP#") == "AM5#"


@pytest.mark.parametrize("kind", ["close", "outage", "reboot"])
def test_connection_faults_hang_up_the_pty_and_it_comes_back(model: MountModel, kind: str) -> None:
    serial = pytest.importorskip("serial")
    server = EmulatorServer(model, port=0, baud=0, pty=True).start()
    try:
        port = serial.Serial(server.pty_path, 9600, timeout=2.0)
        port.write(b":GVP#")
        assert port.read_until(b"#") == b"AM5#"
        getattr(server.faults, {"close": "close_connections", "outage": "outage", "reboot": "reboot"}[kind])(
            *(() if kind == "close" else (0.2,))
        )
        with pytest.raises(serial.SerialException):
            for _ in range(50):
                port.read(1)
        port.close()
        path = server.wait_pty()
        assert path is not None
        again = serial.Serial(path, 9600, timeout=2.0)
        again.write(b":GVP#")
        assert again.read_until(b"#") == b"AM5#"
        again.close()
    finally:
        server.stop()
