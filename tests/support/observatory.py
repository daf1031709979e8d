"""Real third-party Alpaca devices for the observatory interlock: alpaca-simulators (PyPI) in a subprocess.

alpaca-simulators 1.3.2 serves every ASCOM device type with FastAPI and uvicorn; its SafetyMonitor 0 and
Dome 0 are what the interlock reads. They are driven through their own Alpaca API, as an observatory
program would: ``PUT safetymonitor/0/issafe`` (the simulator's own write of IsSafe, read back by the
standard GET) and the Dome's standard ``openshutter``/``closeshutter``. Its Dome starts with the shutter
closed (ShutterStatus 1) and its SafetyMonitor safe. Stopping the process makes both unreachable.

It listens on 127.0.0.1 only, on a free port uvicorn picks (``--port 0``); its configuration file is a
copy in the test's own directory (``--config`` takes an absolute path), so nothing is written into the
installed package and parallel runs do not share state.
"""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import requests

__all__ = ["AlpacaSimulators"]

_LISTENING = re.compile(r"Uvicorn running on http://127\.0\.0\.1:(\d+)")
START_TIMEOUT_S = 30.0


class AlpacaSimulators:
    """One alpaca-simulators process; ``port`` once started. Use as a context manager or call ``stop``."""

    def __init__(self, workdir: Path) -> None:
        self.workdir = workdir
        self.port = 0
        self.proc: subprocess.Popen[str] | None = None
        self.output: list[str] = []

    # -- life ------------------------------------------------------------------------------------

    def start(self) -> AlpacaSimulators:
        config = self.workdir / "alpaca-simulators.yaml"
        code = "import sys; from alpaca_simulators.run_simulator import main; sys.exit(main())"
        self.proc = subprocess.Popen(
            [sys.executable, "-c", code, "--host", "127.0.0.1", "--port", "0", "--config", str(config)],
            cwd=self.workdir, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        found = threading.Event()

        def read() -> None:
            assert self.proc is not None and self.proc.stdout is not None
            for line in self.proc.stdout:
                self.output.append(line.rstrip())
                match = _LISTENING.search(line)
                if match and not found.is_set():
                    self.port = int(match.group(1))
                    found.set()

        threading.Thread(target=read, name="alpaca-simulators-output", daemon=True).start()
        if not found.wait(START_TIMEOUT_S):
            self.stop()
            raise RuntimeError("alpaca-simulators did not start:\n" + "\n".join(self.output[-30:]))
        return self

    def stop(self) -> None:
        """End the process (the devices become unreachable)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)

    def __enter__(self) -> AlpacaSimulators:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- the devices ------------------------------------------------------------------------------

    @property
    def base(self) -> str:
        return f"http://127.0.0.1:{self.port}/api/v1"

    @property
    def monitor_url(self) -> str:
        return f"{self.base}/safetymonitor/0"

    @property
    def roof_url(self) -> str:
        return f"{self.base}/dome/0"

    def _put(self, path: str, **form: str) -> None:
        reply = requests.put(f"{self.base}/{path}", data=form, timeout=10)
        reply.raise_for_status()
        assert reply.json()["ErrorNumber"] == 0, reply.text

    def _get(self, path: str) -> object:
        reply = requests.get(f"{self.base}/{path}", timeout=10)
        reply.raise_for_status()
        return reply.json()["Value"]

    def set_safe(self, safe: bool) -> None:
        self._put("safetymonitor/0/issafe", IsSafe="true" if safe else "false")
        assert self._get("safetymonitor/0/issafe") is safe

    def open_roof(self) -> None:
        self._put("dome/0/openshutter")
        assert self._get("dome/0/shutterstatus") == 0

    def close_roof(self) -> None:
        self._put("dome/0/closeshutter")
        assert self._get("dome/0/shutterstatus") == 1

    def monitor_connected(self) -> bool:
        return bool(self._get("safetymonitor/0/connected"))

    def wait_gone(self, timeout: float = 10.0) -> None:
        """After stop(): the port no longer answers."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                requests.get(f"{self.base}/safetymonitor/0/issafe", timeout=1)
            except requests.RequestException:
                return
            time.sleep(0.1)
        raise AssertionError("alpaca-simulators still answers after stop()")
