"""The Dockerfile, unchanged, built and run with podman.

No container registry is reachable here, so the Dockerfile's base image (its FROM line) is
replaced by a local stand-in with the same name: a debootstrapped Debian bookworm (the release
``python:3.11-slim`` is built on) with its Python 3.11, pip and venv, whose Python is not marked
externally managed (as the official image's is not). It is imported into a private podman
storage under the cache directory, and everything is built and run with ``--pull=never``.
The build fetches the project's dependencies from PyPI, as a user's build does.

The containers run inside a private network namespace (host networking there), so port 11111
and the discovery responder stay private. Checks: the no-argument container serves the emulator
on 11111; the server runs as a non-root user; HEALTHCHECK passes, also with ``--port 11112``;
``/config/config.toml`` is written on start and the UniqueID survives a new container on the same
volume; ``podman stop`` ends it within 10 s with exit code 0. The image size is reported.
"""

from __future__ import annotations

import json
import re
import resource
import shutil
import subprocess
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.platform.chroot import poll_in_netns, private_netns
from tests.platform.conftest import require_root
from tests.platform.roots import CACHE, REPO_ROOT, cache_key, copy_root, host_ca_bundle, pristine_root, run

BASE_PACKAGES = ("python3", "python3-pip", "python3-venv", "python-is-python3", "ca-certificates")
IMAGE = "localhost/alpaca-zwo-test:latest"
PODMAN_RUNROOT = Path("/run/alpaca-zwo-tests/podman")
BUILD_TIMEOUT_S = 900


def _ulimits() -> list[str]:
    """Limits at or below this process's own: lowering a limit needs no privilege, raising it does."""
    nofile = min(resource.getrlimit(resource.RLIMIT_NOFILE)[0], 4096)
    nproc = min(resource.getrlimit(resource.RLIMIT_NPROC)[0], 4096)
    return [f"nofile={nofile}:{nofile}", f"nproc={nproc}:{nproc}"]


def _containers_conf() -> Path:
    """Engine settings that work in a sandbox as well as on a plain host.

    runc copes with cgroup v1, hybrid and v2 alike (crun refuses hybrid); the containers' rlimits
    are this process's own, because raising them needs CAP_SYS_RESOURCE, which a sandbox may lack.
    """
    text = (f"[containers]\ndefault_ulimits = {json.dumps(_ulimits())}\n\n"
            "[engine]\nruntime = \"runc\"\ncgroup_manager = \"cgroupfs\"\nevents_logger = \"file\"\n\n"
            "[network]\nnetwork_backend = \"netavark\"\n")
    PODMAN_RUNROOT.mkdir(parents=True, exist_ok=True)
    path = PODMAN_RUNROOT.parent / "containers.conf"
    path.write_text(text)
    return path


def podman(*args: str) -> list[str]:
    """A podman command on the tests' private storage (kept in the cache between runs).

    podman itself runs in the host's namespaces (``ip netns exec`` would hide the cgroup mounts
    it needs); the containers join the test's private network namespace with ``--network ns:``.
    """
    return ["env", f"CONTAINERS_CONF={_containers_conf()}", "podman", "--root", str(CACHE / "podman-storage"),
            "--runroot", str(PODMAN_RUNROOT), "--storage-driver", "overlay", *args]


def base_image_name() -> str:
    match = re.search(r"^FROM\s+(\S+)", (REPO_ROOT / "Dockerfile").read_text(), re.MULTILINE)
    assert match, "Dockerfile has no FROM line"
    name = match.group(1)
    return name if "/" in name else f"docker.io/library/{name}"


def ensure_base_image(scratch: Path) -> str:
    """Import the stand-in for the FROM image once per (suite, packages, CA bundle); returns its name."""
    name = base_image_name()
    bundle = host_ca_bundle()
    key = cache_key("bookworm", name, *BASE_PACKAGES, bundle.read_text() if bundle else "")
    found = subprocess.run(podman("image", "inspect", "--format", "{{index .Labels \"alpaca-zwo-test-key\"}}", name),
                           capture_output=True, text=True, timeout=120)
    if found.returncode == 0 and found.stdout.strip() == key:
        return name
    root = copy_root(pristine_root("bookworm", BASE_PACKAGES), scratch / "base-root")
    for marker in root.glob("usr/lib/python3*/EXTERNALLY-MANAGED"):
        marker.unlink()  # the official image's Python is not marked; pip installs system-wide there
    if bundle is not None:  # trust what this machine's pip trusts (a TLS-inspecting proxy's CA)
        shutil.copy(bundle, root / "etc/ssl/certs/ca-certificates.crt")
    shutil.rmtree(root / "var/lib/apt/lists", ignore_errors=True)
    tarball = scratch / "base.tar"
    run(["tar", "-C", str(root), "--numeric-owner", "-cf", str(tarball), "."], 600, "tar of the stand-in base")
    run(podman("import", "--change", f"LABEL alpaca-zwo-test-key={key}", "--change", 'CMD ["python3"]',
               "--change", "ENV LANG=C.UTF-8", str(tarball), name), 600, "podman import of the stand-in base")
    shutil.rmtree(root)
    tarball.unlink()
    return name


@pytest.fixture(scope="module")
def image(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    require_root()
    if shutil.which("podman") is None:
        raise RuntimeError("podman not found: scripts/run-tests installs it as root")
    PODMAN_RUNROOT.mkdir(parents=True, exist_ok=True)
    scratch = tmp_path_factory.mktemp("container")
    started = time.monotonic()
    ensure_base_image(scratch)
    based = time.monotonic()
    # docker format keeps HEALTHCHECK (OCI image config has no field for it).
    # The build context is a clone: committed files only, as a user's checkout (and CI's) has them.
    context = scratch / "context"
    run(["git", "clone", "--quiet", "--no-hardlinks", str(REPO_ROOT), str(context)], 300, "git clone")
    limits = [word for limit in _ulimits() for word in ("--ulimit", limit)]  # build ignores default_ulimits
    run(podman("build", "--pull=never", "--network", "host", "--format", "docker", *limits, "-t", IMAGE,
               "-f", str(context / "Dockerfile"), str(context)), BUILD_TIMEOUT_S, "podman build of the Dockerfile")
    subprocess.run(podman("image", "prune", "-f"), capture_output=True, timeout=300)  # earlier builds' layers
    print(f"\nstand-in base ready in {based - started:.0f} s; image built in {time.monotonic() - based:.0f} s")
    yield IMAGE


def _inspect(name: str, fmt: str) -> str:
    return run(podman("inspect", "--format", fmt, name), 60, f"podman inspect {name}").stdout.strip()


def _unique_id(netns: str, port: int) -> str:
    polled = poll_in_netns(netns, f"http://127.0.0.1:{port}/management/v1/configureddevices", 30)
    assert polled.returncode == 0, polled.stdout + polled.stderr
    return json.loads(polled.stdout.strip().splitlines()[-1])["body"]["Value"][0]["UniqueID"]


def _stop(name: str) -> tuple[float, int]:
    started = time.monotonic()
    run(podman("stop", "--time", "10", name), 60, f"podman stop {name}")
    took = time.monotonic() - started
    return took, int(_inspect(name, "{{.State.ExitCode}}"))


@pytest.mark.timeout(2400)
def test_container_builds_serves_keeps_its_id_and_stops_cleanly(root_only: None, image: str) -> None:
    volume = f"azwo-test-{uuid.uuid4().hex[:8]}"
    first, second = f"{volume}-a", f"{volume}-b"
    with private_netns() as netns:
        try:
            network = ["--network", f"ns:/run/netns/{netns}", "-v", f"{volume}:/config"]
            run(podman("run", "-d", "--name", first, *network, image), 120, "podman run (no arguments)")
            polled = poll_in_netns(netns, "http://127.0.0.1:11111/management/apiversions", 60)
            assert polled.returncode == 0, f"no answer on 11111: {polled.stdout}{polled.stderr}"
            status = run(podman("exec", first, "cat", "/proc/1/status"), 60, "podman exec").stdout
            uid = int(re.search(r"^Uid:\s+(\d+)", status, re.MULTILINE).group(1))
            assert uid != 0, "the server runs as root in the container"
            health = subprocess.run(podman("healthcheck", "run", first), capture_output=True,
                                    text=True, timeout=60)
            assert health.returncode == 0, f"HEALTHCHECK failed: {health.stdout}{health.stderr}"
            config = run(podman("exec", first, "cat", "/config/config.toml"), 60, "config").stdout
            unique_id = _unique_id(netns, 11111)
            assert unique_id in config, "the UniqueID served is not the one written to /config/config.toml"
            took, code = _stop(first)
            assert took < 10.0 and code == 0, f"podman stop took {took:.1f} s, exit code {code}"
            logs = run(podman("logs", first), 60, "podman logs")
            assert "alpaca-zwo stopped" in logs.stdout + logs.stderr, "SIGTERM did not take the clean stop path"

            run(podman("run", "-d", "--name", second, *network, image, "--port", "11112"), 120,
                "podman run --port 11112")
            polled = poll_in_netns(netns, "http://127.0.0.1:11112/management/apiversions", 60)
            assert polled.returncode == 0, f"no answer on 11112: {polled.stdout}{polled.stderr}"
            health = subprocess.run(podman("healthcheck", "run", second), capture_output=True,
                                    text=True, timeout=60)
            assert health.returncode == 0, f"HEALTHCHECK with --port 11112 failed: {health.stdout}{health.stderr}"
            assert _unique_id(netns, 11112) == unique_id, "the UniqueID changed with a new container"
            took2, code2 = _stop(second)
            assert took2 < 10.0 and code2 == 0, f"podman stop took {took2:.1f} s, exit code {code2}"
        finally:
            subprocess.run(podman("rm", "-f", first, second), capture_output=True, timeout=120)
            subprocess.run(podman("volume", "rm", "-f", volume), capture_output=True, timeout=60)
    size = int(run(podman("image", "inspect", "--format", "{{.Size}}", image), 60, "image size").stdout.strip())
    base = int(run(podman("image", "inspect", "--format", "{{.Size}}", base_image_name()), 60, "base").stdout.strip())
    print(f"image {size / 1e6:.0f} MB (stand-in base {base / 1e6:.0f} MB, alpaca-zwo layers "
          f"{(size - base) / 1e6:.0f} MB); stop took {took:.1f} s and {took2:.1f} s, exit codes {code} and {code2}")
