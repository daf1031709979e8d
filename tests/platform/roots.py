"""Fresh Debian roots for the platform tests, cached between runs.

``debootstrap`` takes minutes, so each pristine root is built once per (suite, package list) and
kept under CACHE (``/var/cache/alpaca-zwo-tests`` unless ``ALPACA_ZWO_TEST_CACHE`` says otherwise);
a test works on a copy. Builds go to a temporary name and are renamed into place only when
complete, under a lock, so an interrupted run never leaves a half-built root in the cache.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import re
import shutil
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
CACHE = Path(os.environ.get("ALPACA_ZWO_TEST_CACHE", "/var/cache/alpaca-zwo-tests"))
PYTHON_VERSIONS = {"bookworm": "3.11", "trixie": "3.13"}
DEBOOTSTRAP_TIMEOUT_S = 1200
_LAYOUT_VERSION = "1"  # bump when what a root contains changes in a way the key does not show


def apt_mirror() -> str:
    """The Debian mirror this machine's apt uses (its main archive, not the security one)."""
    sources = [Path("/etc/apt/sources.list"), *sorted(Path("/etc/apt/sources.list.d").glob("*"))]
    for path in sources:
        if not path.is_file() or not (path.name.endswith(".list") or path.name.endswith(".sources")):
            continue
        text = path.read_text(errors="replace")
        uris = re.findall(r"^\s*URIs:\s*(.+)$", text, re.MULTILINE)
        uris += re.findall(r"^\s*deb\s+(?:\[[^\]]*\]\s+)?(\S+)", text, re.MULTILINE)
        for line in uris:
            for uri in line.split():
                if uri.rstrip("/").endswith("/debian"):
                    return uri.rstrip("/")
    raise AssertionError("no Debian archive (a URI ending in /debian) in /etc/apt/sources.list*: "
                         "debootstrap needs this machine's mirror")


def cache_key(*parts: str) -> str:
    return hashlib.sha256("\0".join((_LAYOUT_VERSION, *parts)).encode()).hexdigest()[:12]


@contextlib.contextmanager
def _locked(name: str) -> Iterator[None]:
    CACHE.mkdir(parents=True, exist_ok=True)
    with open(CACHE / f".{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        yield


def cached_dir(name: str, build: Callable[[Path], None]) -> Path:
    """CACHE/name, built by ``build(tmpdir)`` the first time and then reused as it is."""
    final = CACHE / name
    if final.is_dir():
        return final
    with _locked(name):
        if final.is_dir():
            return final
        temp = CACHE / f".{name}.building"
        if temp.exists():
            shutil.rmtree(temp)
        temp.mkdir(parents=True)
        build(temp)
        temp.rename(final)
    return final


def run(cmd: list[str], timeout: float, what: str, **kwargs: object) -> subprocess.CompletedProcess[str]:
    """Run a setup command; on failure raise with its output, so a broken mirror reads as such."""
    started = time.monotonic()
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False, **kwargs)
    except subprocess.TimeoutExpired as exc:
        raise AssertionError(f"{what}: no result within {timeout:.0f} s ({' '.join(cmd)})") from exc
    if done.returncode != 0:
        tail = (done.stdout + done.stderr)[-3000:]
        raise AssertionError(f"{what} failed (exit {done.returncode}, {time.monotonic() - started:.0f} s): "
                             f"{' '.join(cmd)}\n{tail}")
    return done


def pristine_root(suite: str, include: tuple[str, ...]) -> Path:
    """A minbase Debian ``suite`` with ``include`` installed, from this machine's mirror; cached."""
    mirror = apt_mirror()
    name = f"root-{suite}-{cache_key(suite, mirror, *sorted(include))}"

    def build(target: Path) -> None:
        run(["debootstrap", "--variant=minbase", f"--include={','.join(include)}", suite, str(target), mirror],
            DEBOOTSTRAP_TIMEOUT_S, f"debootstrap {suite} from {mirror}")
        # Keep the cache small: downloaded .debs are not needed once installed.
        shutil.rmtree(target / "var/cache/apt/archives", ignore_errors=True)
        (target / "var/cache/apt/archives/partial").mkdir(parents=True, exist_ok=True)

    return cached_dir(name, build)


def copy_root(pristine: Path, dest: Path) -> Path:
    """A private, writable copy of a pristine root (cp -a keeps owners, modes and device nodes)."""
    run(["cp", "-a", str(pristine), str(dest)], 600, "copying the cached root")
    return dest


def host_ca_bundle() -> Path | None:
    """The CA bundle this machine's pip is told to trust (a TLS-inspecting proxy's), if any."""
    for var in ("PIP_CERT", "REQUESTS_CA_BUNDLE", "SSL_CERT_FILE"):
        value = os.environ.get(var)
        if value and Path(value).is_file():
            return Path(value)
    return None
