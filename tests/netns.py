"""Private network namespaces for tests that need a real link (broadcast, multicast, mDNS).

Discovery and mDNS can only be tested honestly on a real Ethernet-like link, and doing that on
the machine's own interfaces would spray the LAN (and be flaky on CI). Instead each test gets
namespaces joined by veth, with addresses that exist only inside them: the veth ends are created
directly inside the namespaces, so nothing is ever added to the host's own network stack.

Typical use::

    lan = lan_fixture(2)          # module level: a pytest fixture

    def test_x(lan):
        a, b = lan.hosts
        server = b.spawn_python(CODE, "arg")
        server.expect("READY", timeout=10)
        out = a.python("print('hi')")
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import queue
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

__all__ = [
    "Namespace",
    "NetnsLan",
    "NsProcess",
    "lan_fixture",
    "missing_privilege",
    "netns_lan",
    "require_netns",
]

REPO_ROOT = Path(__file__).resolve().parents[1]
NS_PREFIX = "azwo-"
IFNAME = "veth0"
SUBNET_PREFIX = "10.231.0"  # /24; exists only inside the test namespaces
READY_TIMEOUT = 10.0

_CAPS = {12: "CAP_NET_ADMIN", 21: "CAP_SYS_ADMIN"}  # ip netns needs both (mount + netlink)
_counter = itertools.count()


def missing_privilege() -> str | None:
    """Why namespaces cannot be made here, or None when they can."""
    if not sys.platform.startswith("linux"):
        return "network namespaces are Linux-only"
    try:
        status = Path("/proc/self/status").read_text()
    except OSError as exc:
        return f"cannot read capabilities: {exc}"
    effective = next((line.split()[1] for line in status.splitlines() if line.startswith("CapEff:")), "0")
    caps = int(effective, 16)
    missing = [name for bit, name in _CAPS.items() if not caps >> bit & 1]
    if missing:
        return f"process lacks {' and '.join(missing)}, needed for ip netns"
    return None


def require_netns() -> None:
    """Skip only for missing privileges; a missing ``ip`` is a broken machine, not a reason to skip."""
    reason = missing_privilege()
    if reason:
        pytest.skip(reason)
    if shutil.which("ip") is None:
        raise RuntimeError("iproute2 'ip' not found: apt-get install -y iproute2")


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=15)
    if check and proc.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)} failed ({proc.returncode}): {proc.stderr.strip()}")
    return proc


def _ip_json(*args: str) -> Any:
    out = _ip("-j", *args).stdout.strip()
    return json.loads(out) if out else []


def _veth(name: str, netns: str, peer: str, peer_netns: str) -> None:
    """Create a veth pair with both ends born inside namespaces: the host stack never sees it."""
    _ip("link", "add", name, "netns", netns, "type", "veth", "peer", "name", peer, "netns", peer_netns)


def _child_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO_ROOT), env.get("PYTHONPATH")]))
    env["PYTHONUNBUFFERED"] = "1"
    return env


def cleanup_stale_namespaces() -> None:
    """Delete namespaces left by test runs whose process no longer exists (e.g. killed with -9).

    Names carry the creating pid, so a concurrent run by someone else is never touched.
    """
    listing = _ip("netns", "list", check=False).stdout
    for line in listing.splitlines():
        name = line.split()[0] if line.split() else ""
        if not name.startswith(NS_PREFIX):
            continue
        try:
            pid = int(name[len(NS_PREFIX) :].split("-", 1)[0])
        except ValueError:
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            _ip("netns", "del", name, check=False)
        except PermissionError:
            pass  # alive, someone else's


class NsProcess:
    """A process inside a namespace that talks to the test line by line.

    Reader threads move stdout lines into a queue so a test can wait for a line with a real
    deadline (``readline(timeout)``) instead of sleeping and hoping.
    """

    def __init__(self, argv: Sequence[str], env: dict[str, str]) -> None:
        self.argv = list(argv)
        self.proc = subprocess.Popen(
            self.argv,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        self._lines: queue.Queue[str | None] = queue.Queue()
        self._stderr: list[str] = []
        self._readers = [
            threading.Thread(target=self._pump_stdout, daemon=True),
            threading.Thread(target=self._pump_stderr, daemon=True),
        ]
        for reader in self._readers:
            reader.start()

    def _pump_stdout(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._lines.put(line.rstrip("\n"))
        self._lines.put(None)

    def _pump_stderr(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self._stderr.append(line)

    @property
    def stderr(self) -> str:
        return "".join(self._stderr)

    def readline(self, timeout: float) -> str:
        """Next stdout line; TimeoutError past the deadline, EOFError when the process ended."""
        try:
            line = self._lines.get(timeout=max(0.0, timeout))
        except queue.Empty:
            raise TimeoutError(
                f"no output within {timeout:.1f} s from {self.argv[:4]}; stderr:\n{self.stderr}"
            ) from None
        if line is None:
            self._lines.put(None)  # keep reporting EOF to later callers
            rc = self.proc.wait()
            raise EOFError(f"process exited with {rc} before the expected output; stderr:\n{self.stderr}")
        return line

    def expect(self, prefix: str, timeout: float = READY_TIMEOUT) -> str:
        """Read lines until one starts with ``prefix`` (others are discarded) or the deadline passes."""
        deadline = time.monotonic() + timeout
        while True:
            line = self.readline(deadline - time.monotonic())
            if line.startswith(prefix):
                return line

    def send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def stop(self, timeout: float = 5.0) -> int:
        """Close stdin (the agreed 'please exit'), then terminate/kill if it does not."""
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            with contextlib.suppress(OSError):
                self.proc.stdin.close()
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.proc.terminate()
        try:
            return self.proc.wait(2.0)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


@dataclass
class Namespace:
    """One host on the test LAN."""

    name: str
    ipv4: str
    ipv6_ll: str
    prefixlen: int = 24
    ifname: str = IFNAME
    ifindex: int = 0
    _procs: list[NsProcess] = field(default_factory=list, repr=False)

    def argv(self, *command: str) -> list[str]:
        return ["ip", "netns", "exec", self.name, *command]

    def run(self, *command: str, timeout: float = 30.0, check: bool = True) -> subprocess.CompletedProcess[str]:
        """Run a command in the namespace and wait for it (killed when the timeout passes)."""
        proc = subprocess.run(self.argv(*command), capture_output=True, text=True, timeout=timeout, env=_child_env())
        if check and proc.returncode != 0:
            raise RuntimeError(
                f"{command[:3]} in {self.name} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
            )
        return proc

    def python(self, code: str, *args: str, timeout: float = 30.0) -> str:
        """Run a Python snippet in the namespace and return its stdout (``sys.argv[1:]`` = args)."""
        return self.run(sys.executable, "-c", code, *args, timeout=timeout).stdout

    def spawn_python(self, code: str, *args: str) -> NsProcess:
        """Start a long-running Python snippet; it is killed at teardown if the test did not stop it."""
        proc = NsProcess(self.argv(sys.executable, "-c", code, *args), _child_env())
        self._procs.append(proc)
        return proc

    def kill_all(self) -> None:
        for proc in self._procs:
            proc.kill()
        self._procs.clear()


class NetnsLan:
    """``count`` namespaces on one private Ethernet segment.

    Two hosts are joined by a single veth pair; more hosts hang off a bridge in an extra hub
    namespace (multicast snooping off, so multicast reaches every host like on a dumb switch).
    Every host gets ``10.231.0.(i+1)/24``, ``fe80::(i+1)`` (no DAD, so usable at once), lo up and
    a default route out of its veth so that limited broadcast has a way out.
    """

    def __init__(self, count: int = 2) -> None:
        if count < 2:
            raise ValueError("a LAN needs at least two hosts")
        self.count = count
        self.tag = f"{NS_PREFIX}{os.getpid()}-{next(_counter)}"
        self.hosts: list[Namespace] = []
        self.hub: str | None = None
        self._created: list[str] = []

    @property
    def broadcast(self) -> str:
        return f"{SUBNET_PREFIX}.255"

    def __enter__(self) -> NetnsLan:
        try:
            self._build()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _add_ns(self, name: str) -> None:
        _ip("netns", "add", name)
        self._created.append(name)

    def _build(self) -> None:
        cleanup_stale_namespaces()
        for i in range(self.count):
            name = f"{self.tag}-{chr(ord('a') + i)}"
            self._add_ns(name)
            self.hosts.append(Namespace(name=name, ipv4=f"{SUBNET_PREFIX}.{i + 1}", ipv6_ll=f"fe80::{i + 1}"))
        if self.count == 2:
            a, b = self.hosts
            _veth(IFNAME, a.name, IFNAME, b.name)
        else:
            self.hub = f"{self.tag}-hub"
            self._add_ns(self.hub)
            _ip("-n", self.hub, "link", "add", "br0", "type", "bridge", "mcast_snooping", "0")
            _ip("-n", self.hub, "link", "set", "br0", "addrgenmode", "none")
            for i, host in enumerate(self.hosts):
                port = f"p{i}"
                _veth(IFNAME, host.name, port, self.hub)
                _ip("-n", self.hub, "link", "set", port, "addrgenmode", "none")
                _ip("-n", self.hub, "link", "set", port, "master", "br0", "up")
            _ip("-n", self.hub, "link", "set", "br0", "up")
        for host in self.hosts:
            n = host.name
            _ip("-n", n, "link", "set", "lo", "up")
            # No automatic link-local: a fixed, DAD-free one is usable immediately and predictable.
            _ip("-n", n, "link", "set", IFNAME, "addrgenmode", "none")
            _ip("-n", n, "addr", "add", f"{host.ipv4}/{host.prefixlen}", "brd", "+", "dev", IFNAME)
            _ip("-n", n, "addr", "add", f"{host.ipv6_ll}/64", "dev", IFNAME, "nodad")
            _ip("-n", n, "link", "set", IFNAME, "up")
            _ip("-n", n, "route", "add", "default", "dev", IFNAME)
        self._wait_ready()

    def _wait_ready(self) -> None:
        """Poll until every link can carry traffic; the kernel activates links asynchronously."""
        deadline = time.monotonic() + READY_TIMEOUT
        pending: list[Callable[[], bool]] = []
        for host in self.hosts:
            pending.append(lambda h=host: self._host_ready(h))
        if self.hub is not None:
            for i in range(self.count):
                pending.append(lambda port=f"p{i}": self._bridge_port_forwarding(port))
        while pending:
            pending = [check for check in pending if not check()]
            if not pending:
                return
            if time.monotonic() > deadline:
                raise RuntimeError(f"test LAN {self.tag} not ready within {READY_TIMEOUT} s")
            time.sleep(0.01)  # polling interval of a deadline-bounded wait, not a synchronisation

    @staticmethod
    def _host_ready(host: Namespace) -> bool:
        links = _ip_json("-n", host.name, "link", "show", "dev", IFNAME)
        if not links or links[0].get("operstate") != "UP":
            return False
        host.ifindex = int(links[0]["ifindex"])
        addrs = _ip_json("-n", host.name, "-6", "addr", "show", "dev", IFNAME)
        infos = addrs[0].get("addr_info", []) if addrs else []
        if not any(a.get("local") == host.ipv6_ll and not a.get("tentative") for a in infos):
            return False
        routes = _ip_json("-n", host.name, "-6", "route", "show", "table", "local", "dev", IFNAME)
        return any(r.get("dst") == "ff00::/8" for r in routes)

    def _bridge_port_forwarding(self, port: str) -> bool:
        assert self.hub is not None
        links = _ip_json("-n", self.hub, "-d", "link", "show", "dev", port)
        slave = links[0].get("linkinfo", {}).get("info_slave_data", {}) if links else {}
        return slave.get("state") == "forwarding"

    def close(self) -> None:
        """Kill what runs inside, then delete the namespaces (veth and bridge go with them)."""
        for host in self.hosts:
            host.kill_all()
        errors = []
        for name in reversed(self._created):
            proc = _ip("netns", "del", name, check=False)
            if proc.returncode != 0:
                errors.append(f"{name}: {proc.stderr.strip()}")
        self._created.clear()
        if errors:
            raise RuntimeError("could not delete test namespaces: " + "; ".join(errors))


@contextlib.contextmanager
def netns_lan(count: int = 2) -> Iterator[NetnsLan]:
    """Context manager: skip for missing privileges, build the LAN, always tear it down."""
    require_netns()
    with NetnsLan(count) as lan:
        yield lan


def lan_fixture(count: int = 2, scope: str = "function") -> Any:
    """Make a pytest fixture yielding a fresh :class:`NetnsLan` of ``count`` hosts."""

    @pytest.fixture(scope=scope)  # type: ignore[call-overload]
    def _lan() -> Iterator[NetnsLan]:
        with netns_lan(count) as lan:
            yield lan

    return _lan
