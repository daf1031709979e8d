"""The server as users run it: ``python -m alpaca_zwo`` in its own process, optionally under a wrapper.

A wrapper such as Debian's ``faketime -f -3h`` gives the server a wrong clock while the test (and a
separate emulator process) keep the true one, the way a Raspberry Pi without network boots.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from tests.support.emulator import ENV, ROOT, OutputLines

#: The monotonic clock stays real (a faked one hangs Python's lock timeouts under libfaketime 0.9.10), and
#: faketime/sitecustomize.py mends time.sleep, which that mode breaks: see that module.
FAKETIME_ENV = {"FAKETIME_DONT_FAKE_MONOTONIC": "1",
                "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent / "faketime"), ENV["PYTHONPATH"]])}


class ServerProcess:
    """``[wrapper...] python -m alpaca_zwo --port 0 --discovery-port 0 --host 127.0.0.1 ARGS...``,
    its log in ``log_path`` and its HTTP port read from the start banner."""

    def __init__(self, tmp_path: Path, *args: str, wrapper: Sequence[str] = (), env: Mapping[str, str] | None = None,
                 config: str = "[server]\nmdns = false\n", timeout: float = 30.0) -> None:
        config_path = tmp_path / "config.toml"
        config_path.write_text(config)
        self.log_path = tmp_path / "server.log"
        with open(self.log_path, "w") as log_file:
            self.process = subprocess.Popen(
                [*wrapper, sys.executable, "-m", "alpaca_zwo", "--port", "0", "--discovery-port", "0",
                 "--host", "127.0.0.1", "--config", str(config_path), "--log-level", "INFO", *args],
                stdout=subprocess.PIPE, stderr=log_file, text=True, env={**ENV, **(env or {})}, cwd=ROOT,
                start_new_session=True)  # a group of its own: a wrapper (faketime) forks the server as its child
        assert self.process.stdout is not None
        self.lines = OutputLines(self.process.stdout)
        try:
            self.port = int(self.lines.expect(r"Alpaca API:\s+http://127\.0\.0\.1:(\d+)/", timeout).group(1))
        except BaseException:
            self.stop()
            raise

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def stop(self) -> None:
        """End the server and whatever its wrapper started: the whole process group, so a server that a
        wrapper forked (faketime does) is never left running after the test."""
        self._signal_group(signal.SIGTERM)
        try:
            self.process.wait(20)
        except subprocess.TimeoutExpired:
            self._signal_group(signal.SIGKILL)
            self.process.wait(10)
        self._signal_group(signal.SIGKILL)  # the wrapper's child, should the wrapper have gone first

    def _signal_group(self, signum: int) -> None:
        with contextlib.suppress(ProcessLookupError, PermissionError):  # the group is gone already
            os.killpg(self.process.pid, signum)
