"""The processes under test: emulator, alpaca-zwo server and the peer simulator, each its own process.

Each is started the way a user starts it (its own command line), on loopback ports chosen by the
OS (port 0), and found by reading the address it prints. Output goes to files in the run
directory, never to pipes nobody drains (a full pipe would stall the server and look like a slow
server). Only processes started here are ever stopped, by their own pid.
"""

from __future__ import annotations

import ast
import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import psutil

from alpaca_zwo.emulator.control import ask

REPO = Path(__file__).resolve().parent.parent

__all__ = [
    "Emulator",
    "Proc",
    "cycle_aligned",
    "emulator_log_exchanges",
    "emulator_log_times",
    "start_alpaca_zwo",
    "start_emulator",
    "start_peer",
]


@dataclass
class Proc:
    """A started process, its log files and the port(s) it announced."""

    name: str
    popen: subprocess.Popen[bytes]
    stdout: Path
    stderr: Path
    ports: dict[str, int] = field(default_factory=dict)
    cpus: tuple[int, ...] | None = None

    @property
    def pid(self) -> int:
        return self.popen.pid

    @property
    def port(self) -> int:
        return self.ports["http"]

    def rss_mb(self) -> float:
        return psutil.Process(self.pid).memory_info().rss / 1e6

    def cpu_s(self) -> float:
        times = psutil.Process(self.pid).cpu_times()
        return float(times.user + times.system)

    def threads(self) -> int:
        return psutil.Process(self.pid).num_threads()

    def stop(self, timeout: float = 10.0) -> None:
        if self.popen.poll() is not None:
            return
        self.popen.send_signal(signal.SIGTERM)
        try:
            self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self.popen.wait(5.0)


def _spawn(name: str, argv: list[str], run_dir: Path, patterns: dict[str, str], *, source: str = "stdout",
           timeout: float = 30.0, env: dict[str, str] | None = None, cpus: tuple[int, ...] | None = None) -> Proc:
    stdout = run_dir / f"{name}.out"
    stderr = run_dir / f"{name}.err"

    def pin() -> None:
        if cpus and hasattr(os, "sched_setaffinity"):
            os.sched_setaffinity(0, cpus)

    with stdout.open("wb") as out, stderr.open("wb") as err:
        popen = subprocess.Popen(argv, stdout=out, stderr=err, stdin=subprocess.DEVNULL,
                                 env={**os.environ, **(env or {})}, preexec_fn=pin if cpus else None)
    proc = Proc(name, popen, stdout, stderr, cpus=cpus)
    watched = stdout if source == "stdout" else stderr
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        text = watched.read_text(errors="replace")
        for key, pattern in patterns.items():
            if key not in proc.ports:
                match = re.search(pattern, text, re.MULTILINE)
                if match:
                    proc.ports[key] = int(match.group(1))
        if len(proc.ports) == len(patterns):
            return proc
        if popen.poll() is not None:
            break
        time.sleep(0.05)
    proc.stop()
    raise RuntimeError(f"{name} did not announce {sorted(set(patterns) - set(proc.ports))}: "
                       f"{stdout.read_text(errors='replace')[-800:]} {stderr.read_text(errors='replace')[-800:]}")


class Emulator:
    """The emulator process plus its loopback control channel (``stats`` counts the mount line)."""

    def __init__(self, proc: Proc) -> None:
        self.proc = proc

    def control(self, command: str) -> dict[str, Any]:
        return ask(self.proc.ports["control"], command)

    def stats(self) -> dict[str, Any]:
        """Totals over every line since start, stamped with the wall-clock time they were read."""
        answer = self.control("stats")
        totals = answer["stats"]["total"]
        return {"time": time.time(), "bytes_in": totals["bytes_in"], "bytes_out": totals["bytes_out"],
                "exchanges": totals["exchanges"], "replies": totals["replies"]}


def start_emulator(run_dir: Path, baud: int, cpus: tuple[int, ...] | None, extra: tuple[str, ...] = ()) -> Emulator:
    """The emulator at ``baud``; DEBUG logging stamps every request when its last byte arrives. ``extra``:
    more of its options (``--start-time``, ``--mode`` ...)."""
    argv = [sys.executable, "-m", "alpaca_zwo.emulator", "--port", "0", "--baud", str(baud), "--control-port", "0",
            "--log-level", "DEBUG", *extra]
    proc = _spawn("emulator", argv, run_dir, {"tcp": r"^tcp [\d.]+:(\d+)$", "control": r"^control [\d.]+:(\d+)$"},
                  cpus=cpus)
    return Emulator(proc)


def start_alpaca_zwo(run_dir: Path, device_port: int, cpus: tuple[int, ...] | None, *,
                     threads: int | None = None, patches: str = "", env: dict[str, str] | None = None) -> Proc:
    """``python -m alpaca_zwo`` with a fresh config file, exactly as the README starts it.

    ``threads`` overrides the config's waitress worker-thread count (for the thread sweep);
    ``patches`` runs it through :mod:`benchmarks.patched_server` to measure candidate changes.
    """
    config = run_dir / "config.toml"
    if threads is not None:
        config.write_text(f"[server]\nthreads = {threads}\n")
    module = ["-m", "benchmarks.patched_server", "--patch", patches, "--"] if patches else ["-m", "alpaca_zwo"]
    argv = [sys.executable, *module, "--host", "127.0.0.1", "--port", "0", "--discovery-port", "0",
            "--config", str(config), "--device", f"socket://127.0.0.1:{device_port}"]
    paths = [str(REPO), os.environ.get("PYTHONPATH", ""), (env or {}).get("PYTHONPATH", "")]
    env = {**(env or {}), "PYTHONPATH": os.pathsep.join(filter(None, paths))}
    return _spawn("alpaca-zwo", argv, run_dir, {"http": r"Alpaca API:\s+http://127\.0\.0\.1:(\d+)/"}, cpus=cpus,
                  env=env)


def start_peer(run_dir: Path, cpus: tuple[int, ...] | None, *, access_log: bool = True) -> Proc:
    """The peer ``alpaca-simulators`` (PyPI), on loopback.

    ``access_log=True`` is its own console script as shipped (uvicorn logs every request at INFO);
    ``False`` runs the same app under the same uvicorn settings minus the access log, so the
    comparison cannot be blamed on the peer's logging.
    """
    name = "peer" if access_log else "peer-nolog"
    if access_log:
        script = Path(sys.executable).with_name("alpaca-simulators")
        argv = [str(script), "--host", "127.0.0.1", "--port", "0"]
        env = None
    else:
        code = ("import uvicorn; uvicorn.run('alpaca_simulators.main:app', host='127.0.0.1', port=0, "
                "timeout_keep_alive=300, access_log=False)")
        argv = [sys.executable, "-c", code]
        env = {"ASTRA_SIMULATORS_CONFIG": "config.yaml"}
    return _spawn(name, argv, run_dir, {"http": r"Uvicorn running on http://127\.0\.0\.1:(\d+)"}, source="stderr",
                  env=env, cpus=cpus)


_LOG_LINE = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d),(\d{3}) DEBUG alpaca_zwo\.emulator\.server: "
                       r"line \d+ :(\S*?)# -> ")


def emulator_log_times(path: Path, commands: set[str]) -> list[tuple[float, str]]:
    """(wall-clock time, command) of every logged request in ``commands``, in log order.

    The emulator logs a request when its last byte has arrived at the paced line rate, with
    millisecond stamps from the logging module (truncated, so +0.5 ms is the unbiased estimate).
    """
    found = []
    with path.open(errors="replace") as lines:
        for line in lines:
            match = _LOG_LINE.match(line)
            if match and match.group(3) in commands:
                stamp = datetime.strptime(match.group(1), "%Y-%m-%d %H:%M:%S").timestamp()
                found.append((stamp + int(match.group(2)) / 1000.0 + 0.0005, match.group(3)))
    return found


_EXCHANGE = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d),(\d{3}) DEBUG alpaca_zwo\.emulator\.server: "
                       r"line \d+ :(.*)# -> (None|'.*'|\".*\")$")


def emulator_log_exchanges(path: Path, start: float, end: float) -> list[tuple[float, str, int, int]]:
    """(time, command body, request bytes, reply bytes) of every logged exchange in [start, end)."""
    found = []
    with path.open(encoding="latin-1") as lines:
        for line in lines:
            match = _EXCHANGE.match(line.rstrip("\n"))
            if not match:
                continue
            stamp = datetime.strptime(match.group(1), "%Y-%m-%d %H:%M:%S").timestamp() + int(match.group(2)) / 1000.0
            if start <= stamp < end:
                reply = match.group(4)
                size = 0 if reply == "None" else len(ast.literal_eval(reply))
                found.append((stamp, match.group(3), len(match.group(3)) + 2, size))
    return found


def cycle_aligned(path: Path, start: float, end: float, marker: str = "GMEQ") -> dict[str, float] | None:
    """Line use over whole poll cycles: from the first poll in the window to the last one.

    A window cut at arbitrary times holds a varying number of 0.75 s poll cycles (+-1 cycle is
    +-4% of a 20 s window), which would swamp a 5% flatness check; counting from one cycle start
    to another removes that quantisation.
    """
    exchanges = emulator_log_exchanges(path, start, end)
    polls = [t for t, body, _, _ in exchanges if body == marker]
    if len(polls) < 3:
        return None
    first, last = polls[0], polls[-1]
    inside = [e for e in exchanges if first <= e[0] < last]
    span = last - first
    total = sum(e[2] + e[3] for e in inside)
    return {
        "bytes_per_s": round(total / span, 1),
        "exchanges_per_s": round(len(inside) / span, 2),
        "poll_period_s": round(span / (len(polls) - 1), 3),
        "cycles": len(polls) - 1,
    }


def free_cpus() -> tuple[int, ...]:
    with contextlib.suppress(AttributeError):
        return tuple(sorted(os.sched_getaffinity(0)))
    return tuple(range(os.cpu_count() or 1))
