"""The emulator as a separate process (``python -m alpaca_zwo.emulator``), driven over its endpoints.

Tests that need the mount to outlive the server (shutdown), or that test the emulator's command
line itself, run it this way; everything else uses the in-process ``MountModel``/``EmulatorServer``.
"""

from __future__ import annotations

import os
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import IO, Any

import pytest

from alpaca_zwo.emulator.control import ask

ROOT = Path(__file__).resolve().parents[2]
#: The child imports this checkout and flushes every line at once.
ENV = {**os.environ, "PYTHONUNBUFFERED": "1",
       "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
START_TIMEOUT_S = 20.0


class OutputLines:
    """Lines of a child's output, readable with a deadline (a blocking readline could hang the test)."""

    def __init__(self, stream: IO[str]) -> None:
        self.seen: list[str] = []
        self._queue: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._pump, args=(stream,), daemon=True).start()

    def _pump(self, stream: IO[str]) -> None:
        for line in stream:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def expect(self, pattern: str, timeout: float = START_TIMEOUT_S) -> re.Match[str]:
        """The first line (seen or still to come) matching ``pattern``; fail at the deadline or at EOF."""
        deadline = time.monotonic() + timeout
        regex = re.compile(pattern)
        checked = 0
        while True:
            for line in self.seen[checked:]:
                match = regex.search(line)
                if match:
                    return match
            checked = len(self.seen)
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                pytest.fail(f"no line matching {pattern!r} within {timeout} s; saw {self.seen}")
            try:
                line = self._queue.get(timeout=remaining)
            except queue.Empty:
                continue
            if line is None:
                pytest.fail(f"the process ended before printing {pattern!r}; saw {self.seen}")
            self.seen.append(line)


class EmulatorProcess:
    """A running ``python -m alpaca_zwo.emulator --port 0 ARGS...`` and the endpoints it printed."""

    def __init__(self, *args: str, timeout: float = START_TIMEOUT_S) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "alpaca_zwo.emulator", "--port", "0", *args],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=ENV, cwd=ROOT)
        assert self.proc.stdout is not None
        self.lines = OutputLines(self.proc.stdout)
        self.endpoints: dict[str, str] = {}
        wanted = ["tcp"] + [name for flag, name in (("--control-port", "control"), ("--pty", "pty")) if flag in args]
        try:
            for name in wanted:  # the endpoint lines come first and are flushed at once
                self.endpoints[name] = self.lines.expect(rf"^{name} (\S+)$", timeout).group(1)
        except BaseException:
            self.kill()
            raise

    def port(self, name: str = "tcp") -> int:
        return int(self.endpoints[name].rsplit(":", 1)[1])

    def control(self, command: str) -> dict[str, Any]:
        """One control-channel command and its JSON answer (``ok`` may be false)."""
        return ask(self.port("control"), command)

    def state(self) -> dict[str, Any]:
        """The mount's state snapshot; the command must succeed."""
        answer = self.control("state")
        assert answer["ok"], answer
        state: dict[str, Any] = answer["state"]
        return state

    def terminate(self, timeout: float = 10.0) -> int:
        """SIGTERM and the exit code (killed if it does not exit in time)."""
        self.proc.send_signal(signal.SIGTERM)
        try:
            return self.proc.wait(timeout=timeout)
        finally:
            if self.proc.poll() is None:
                self.kill()

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(10.0)
