"""The README's first set-up command, as written, on fresh Debian 12 (Python 3.11) and 13 (3.13).

For each suite: a pristine minbase root from this machine's apt mirror (cached) with python3 and
python3-venv (the one ``sudo apt install`` line the README names), a copy of it, a non-root user
with a ``git clone`` of this repository (committed files only), and the README's command read
from that clone's README at test time, so the two cannot drift. The command runs as that user,
with the system's own Python (PEP 668 marker in place), in a private network namespace; the
server must answer ``GET /management/apiversions`` on port 11111 within 60 s of the install.

Packages come from PyPI: they are downloaded once per suite and dependency set on the host's
network (by the root's own pip, so the wheels fit its Python) into a cached wheelhouse, and the
README's ``pip install`` finds them there through pip's own ``PIP_FIND_LINKS``/``PIP_NO_INDEX``
settings, because the namespace the server runs in has no route anywhere.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.platform.chroot import chroot_command, poll_in_netns, private_netns, user_ids
from tests.platform.roots import (
    PYTHON_VERSIONS,
    REPO_ROOT,
    cache_key,
    cached_dir,
    copy_root,
    host_ca_bundle,
    pristine_root,
    run,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT_PACKAGES = ("python3", "python3-venv", "ca-certificates")
USER = "astro"
INSTALL_TIMEOUT_S = 900  # the README command's venv + pip install, from the local wheelhouse
ANSWER_WITHIN_S = 60  # from the end of the install to the first answer


def readme_setup_command(readme: Path) -> str:
    """The first command of the README's set-up section: the one ```sh block's only line."""
    section = readme.read_text(encoding="utf-8").split("## Set-up on a fresh machine", 1)[1].split("\n## ", 1)[0]
    block = re.search(r"```sh\n(.*?)```", section, re.DOTALL)
    assert block, "README: no ```sh block in 'Set-up on a fresh machine'"
    lines = [line for line in block.group(1).splitlines() if line.strip() and not line.lstrip().startswith("#")]
    assert len(lines) == 1, f"README: the first set-up block should be one command, found {lines}"
    return lines[0]


def _requirements() -> list[str]:
    project = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())
    return [*project["build-system"]["requires"], *project["project"]["dependencies"]]


def _wheelhouse(suite: str, pristine: Path, scratch: Path) -> Path:
    """Wheels for the project and its build, fetched by the suite's own pip (host network); cached."""
    requirements = _requirements()

    def build(target: Path) -> None:
        root = copy_root(pristine, scratch / "download-root")
        env = {}
        bundle = host_ca_bundle()
        if bundle is not None:  # the machine trusts a TLS-inspecting proxy: so must pip in the root
            shutil.copy(bundle, root / "etc/ssl/certs/host-bundle.crt")
            env["PIP_CERT"] = "/etc/ssl/certs/host-bundle.crt"
        shutil.copy("/etc/resolv.conf", root / "etc/resolv.conf")
        run(chroot_command(root, ["python3", "-m", "venv", "/opt/download"]), 300, f"{suite}: venv for download")
        run(chroot_command(root, ["/opt/download/bin/pip", "download", "--disable-pip-version-check",
                                  "--dest", "/wheelhouse", *requirements],
                           env=env, binds={target: "/wheelhouse"}), 900, f"{suite}: pip download from PyPI")
        shutil.rmtree(root)

    return cached_dir(f"wheels-{suite}-{cache_key(suite, *requirements)}", build)


class _Installed:
    """Notices the moment the install has put the ``alpaca-zwo`` command in place."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.at: float | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def _watch(self) -> None:
        while not self._stop.wait(0.05):
            if self.path.exists():
                self.at = time.monotonic()
                return

    def wait(self, timeout: float) -> bool:
        self._thread.join(timeout)
        return self.at is not None

    def stop(self) -> None:
        self._stop.set()


@pytest.mark.timeout(2400)
@pytest.mark.parametrize("suite", ["bookworm", "trixie"])
def test_readme_setup_command_on_fresh_debian(suite: str, root_only: None, tmp_path: Path) -> None:
    for tool in ("debootstrap", "ip", "unshare", "git"):
        assert shutil.which(tool), f"{tool} not found: scripts/run-tests installs it as root"
    started = time.monotonic()
    pristine = pristine_root(suite, ROOT_PACKAGES)
    wheels = _wheelhouse(suite, pristine, tmp_path)
    prepared = time.monotonic()
    root = copy_root(pristine, tmp_path / "root")
    version = PYTHON_VERSIONS[suite]
    assert (root / f"usr/lib/python{version}/EXTERNALLY-MANAGED").exists(), "the system Python is not PEP 668-marked"

    run(chroot_command(root, ["useradd", "--create-home", "--shell", "/bin/bash", USER]), 60, "useradd")
    uid, gid = user_ids(root, USER)
    checkout = root / "home" / USER / "alpaca-zwo"
    run(["git", "clone", "--quiet", "--no-hardlinks", str(REPO_ROOT), str(checkout)], 300, "git clone")
    run(["chown", "-R", f"{uid}:{gid}", str(root / "home" / USER)], 60, "chown")
    command = readme_setup_command(checkout / "README.md")

    log_path = tmp_path / "server.log"
    installed = _Installed(checkout / ".venv/bin/alpaca-zwo")
    with private_netns() as netns, open(log_path, "w") as log:
        proc = subprocess.Popen(
            chroot_command(root, ["bash", "-c", f"cd ~/alpaca-zwo && {command}"], user=(uid, gid), netns=netns,
                           env={"HOME": f"/home/{USER}", "USER": USER, "LOGNAME": USER,
                                "PIP_NO_INDEX": "1", "PIP_FIND_LINKS": "/wheelhouse"},
                           binds={wheels: "/wheelhouse"}),
            stdout=log, stderr=subprocess.STDOUT)
        try:
            if not installed.wait(INSTALL_TIMEOUT_S):
                pytest.fail(f"{suite}: `{command}` did not install within {INSTALL_TIMEOUT_S} s (exit "
                            f"{proc.poll()}):\n{log_path.read_text()[-3000:]}")
            assert installed.at is not None
            remaining = ANSWER_WITHIN_S - (time.monotonic() - installed.at)
            polled = poll_in_netns(netns, "http://127.0.0.1:11111/management/apiversions", max(remaining, 1.0))
            answered_after = time.monotonic() - installed.at
            answer = json.loads(polled.stdout.strip().splitlines()[-1]) if polled.stdout.strip() else {}
            assert polled.returncode == 0 and answer.get("body", {}).get("Value") == [1], (
                f"{suite}: no answer on 11111 within {ANSWER_WITHIN_S} s of the install ({answer}, exit "
                f"{proc.poll()}):\n{log_path.read_text()[-3000:]}")
            assert answered_after <= ANSWER_WITHIN_S
        finally:
            installed.stop()
            # private_netns() stops everything in the namespace; the command's shell goes with it.
    proc.wait(timeout=30)
    venv_python = checkout / f".venv/bin/python{version}"
    assert venv_python.exists(), f"the venv is not on the system's Python {version}"
    config = root / "home" / USER / ".config/alpaca-zwo/config.toml"
    assert config.exists() and config.stat().st_uid == uid, "the server did not run as the user"
    missing = _second_command_as_user(root, uid, gid)
    print(f"{suite}: Python {version}; cache ready after {prepared - started:.0f} s; "
          f"answered {answered_after:.1f} s after the install; `{command}`; run-tests asks for: {' '.join(missing)}")


def _second_command_as_user(root: Path, uid: int, gid: int) -> list[str]:
    """``./scripts/run-tests`` as the user on the fresh system: one ``sudo apt-get install`` line
    naming packages that exist in this release (checked with the root's own apt), and exit 1."""
    done = subprocess.run(
        chroot_command(root, ["bash", "-c", "cd ~/alpaca-zwo && ./scripts/run-tests -q"], user=(uid, gid),
                       env={"HOME": f"/home/{USER}", "USER": USER}),
        capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, f"run-tests as a user exited {done.returncode}:\n{done.stdout}{done.stderr}"
    lines = [line.strip() for line in done.stderr.splitlines() if "sudo apt-get install" in line]
    assert len(lines) == 1, done.stderr
    packages = lines[0].split("sudo apt-get install -y ", 1)[1].split()
    assert {"chromium", "chromium-driver", "iproute2", "indi-bin"} <= set(packages), packages
    assert not {"debootstrap", "podman"} & set(packages), "root-only test tools asked of a user"
    shown = run(chroot_command(root, ["apt-cache", "show", "--no-all-versions", *packages]), 120, "apt-cache show")
    assert shown.stdout.count("\nPackage: ") + shown.stdout.startswith("Package: ") >= len(packages)
    return packages
