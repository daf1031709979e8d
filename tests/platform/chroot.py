"""Run commands in a Debian root: as root or as a user, on the host's network or in a private netns.

Every run gets its own mount namespace (``unshare --mount``) in which /proc and /dev are mounted
into the root, so nothing stays mounted on the host when the run ends, however it ends. A run in
a network namespace sees only its own loopback: the server's port 11111 and its UDP discovery
responder stay private, and nothing it sends can leave the machine.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import signal
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

BASE_ENV = {"PATH": "/usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin", "LANG": "C.UTF-8"}


def chroot_command(root: Path, argv: list[str], *, user: tuple[int, int] | None = None,
                   env: dict[str, str] | None = None, binds: dict[Path, str] | None = None,
                   netns: str | None = None) -> list[str]:
    """The host command line that runs ``argv`` inside ``root`` (optionally as uid:gid, in ``netns``)."""
    mounts = [f"mount -t proc proc {shlex.quote(str(root / 'proc'))}",
              f"mount --rbind /dev {shlex.quote(str(root / 'dev'))}"]
    for source, target in (binds or {}).items():
        inside = root / target.lstrip("/")
        mounts.append(f"mkdir -p {shlex.quote(str(inside))} && mount --bind {shlex.quote(str(source))} "
                      f"{shlex.quote(str(inside))}")
    userspec = [f"--userspec={user[0]}:{user[1]}"] if user else []
    full_env = {**BASE_ENV, **(env or {})}
    inner = ["chroot", *userspec, str(root), "/usr/bin/env", "-i", *(f"{k}={v}" for k, v in full_env.items()),
             *argv]
    script = " && ".join(mounts) + " && exec " + shlex.join(inner)
    cmd = ["unshare", "--mount", "--propagation", "private", "--", "sh", "-c", script]
    return ["ip", "netns", "exec", netns, *cmd] if netns else cmd


def user_ids(root: Path, name: str) -> tuple[int, int]:
    for line in (root / "etc/passwd").read_text().splitlines():
        fields = line.split(":")
        if fields[0] == name:
            return int(fields[2]), int(fields[3])
    raise KeyError(name)


@contextlib.contextmanager
def private_netns() -> Iterator[str]:
    """A network namespace with only loopback (up); every process left in it is killed at the end."""
    name = f"azwo-plat-{uuid.uuid4().hex[:8]}"
    subprocess.run(["ip", "netns", "add", name], check=True, capture_output=True, timeout=30)
    try:
        subprocess.run(["ip", "-n", name, "link", "set", "lo", "up"], check=True, capture_output=True, timeout=30)
        yield name
    finally:
        kill_netns_processes(name)
        subprocess.run(["ip", "netns", "del", name], capture_output=True, timeout=30)


def kill_netns_processes(name: str, grace: float = 10.0) -> None:
    """SIGTERM everything in the namespace, then SIGKILL what is left after ``grace`` seconds."""
    def pids() -> list[int]:
        out = subprocess.run(["ip", "netns", "pids", name], capture_output=True, text=True, timeout=30).stdout
        return [int(p) for p in out.split()]

    for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, 5.0)):
        for pid in pids():
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, sig)
        deadline = time.monotonic() + wait
        while pids() and time.monotonic() < deadline:
            time.sleep(0.1)


POLL = """
import json, sys, time, urllib.request
deadline = time.monotonic() + float(sys.argv[2])
last = None
while time.monotonic() < deadline:
    try:
        with urllib.request.urlopen(sys.argv[1], timeout=2) as reply:
            print(json.dumps({"status": reply.status, "body": json.loads(reply.read())}))
            sys.exit(0)
    except OSError as exc:
        last = repr(exc)
    time.sleep(0.2)
print(json.dumps({"error": last}))
sys.exit(1)
"""


def poll_in_netns(netns: str, url: str, timeout: float) -> subprocess.CompletedProcess[str]:
    """GET ``url`` from inside ``netns`` until it answers or ``timeout`` passes (one JSON line)."""
    return subprocess.run(["ip", "netns", "exec", netns, sys.executable, "-c", POLL, url, str(timeout)],
                          capture_output=True, text=True, timeout=timeout + 30)
