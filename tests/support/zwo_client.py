"""A program on the shared ZWO-protocol port, and the ways a program can misbehave there.

``ZwoClient`` is what every test speaking to the port uses. ``offend`` plays the offenders (junk mixed into
real commands, oversized garbage, a command flood, garbage dressed with real commands, connection storms):
tests/bridges/test_zwo_port.py checks that each is dropped alone, and benchmarks/zwo_port_flood.py measures
what they cost an Alpaca client meanwhile.
"""

from __future__ import annotations

import contextlib
import random
import socket
import time

from alpaca_zwo.zwo import protocol
from alpaca_zwo.zwo.protocol import ReplyKind, reply_complete


class ZwoClient:
    """A program on the ZWO port: sends one command, reads exactly the reply its kind has."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def ask(self, command: str, timeout: float = 5.0, kind: ReplyKind | None = None) -> bytes:
        """The reply to ``command``, read as its kind says (``kind`` for text holding several commands)."""
        if kind is None:
            match = protocol.match_command(command[1:-1])
            kind = match.command.kind if match else ReplyKind.NONE
        self.sock.sendall(command.encode("latin-1"))
        if kind is ReplyKind.NONE:
            return b""
        data = b""
        deadline = time.monotonic() + timeout
        while not reply_complete(kind, data):
            self.sock.settimeout(max(0.01, deadline - time.monotonic()))
            chunk = self.sock.recv(1)
            if not chunk:
                raise ConnectionError(f"closed while waiting for the reply to {command}")
            data += chunk
        return data

    def silent(self, command: str, window: float = 0.4) -> bool:
        """True if nothing at all comes back within ``window`` (a no-reply command, or a refusal)."""
        self.sock.sendall(command.encode("latin-1"))
        self.sock.settimeout(window)
        try:
            return self.sock.recv(64) == b""  # b"": closed, also nothing
        except TimeoutError:
            return True

    def closed_by_server(self, timeout: float = 5.0) -> bool:
        self.sock.settimeout(timeout)
        try:
            while self.sock.recv(4096):
                pass
            return True
        except (ConnectionResetError, BrokenPipeError):
            return True
        except TimeoutError:
            return False

    def close(self) -> None:
        self.sock.close()


def offend(port: int, rng: random.Random) -> None:
    """Every offence once, each checked: the offender is answered while it behaves and closed when it does not.

    Raises AssertionError naming the first offence the port did not handle so.
    """
    # A program mixing junk into real commands is resynchronised and answered correctly (junk after its first
    # command: before it, junk closes the connection, tests/bridges/test_zwo_port_door.py).
    junk = ZwoClient(port)
    assert junk.ask(":GVP#") == b"AM5#"
    for _ in range(20):
        junk.sock.sendall(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 40))).replace(b":", b"").
                          replace(b"#", b""))
        assert junk.ask("#:GVP#", kind=ReplyKind.TEXT) == b"AM5#", "junk between commands"
    junk.close()
    # Oversized garbage from a program: a long run without a known command, and a runaway command body.
    garbage = ZwoClient(port)
    assert garbage.ask(":GVP#") == b"AM5#"
    garbage.sock.sendall(b":" + b"x" * 20000)
    assert garbage.closed_by_server(), "a runaway command body"
    random_bytes = ZwoClient(port)
    assert random_bytes.ask(":GVP#") == b"AM5#"
    random_bytes.sock.sendall(bytes(rng.randrange(256) for _ in range(20000)))
    assert random_bytes.closed_by_server(), "20 kB of random bytes"
    # A flood of commands far beyond what any driver sends.
    flood = ZwoClient(port)
    flood.sock.sendall(b":GVP#" * 5000)
    assert flood.closed_by_server(), "a flood of 5,000 commands"
    # Garbage dressed up with a real command every 4 KB: dropped for its byte rate.
    dressed = ZwoClient(port)
    assert dressed.ask(":GVP#") == b"AM5#"
    with contextlib.suppress(OSError):
        for _ in range(100):
            dressed.sock.sendall(b"x" * 4000 + b":GVP#")
    assert dressed.closed_by_server(), "garbage dressed with a command every 4 kB"
    # 100 connections opened and dropped: in parallel (beyond max_clients) and one after another.
    storm = [socket.create_connection(("127.0.0.1", port), timeout=5) for _ in range(50)]
    for sock in storm:
        sock.close()
    for _ in range(50):
        sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        sock.sendall(b":GR#")
        sock.close()
