"""Every runtime dependency installs from PyPI without a compiler on a Raspberry Pi's CPU.

The Dockerfile (python:3.11-slim, no compiler) has to build unchanged for arm64 and armv7 Pis,
and the README's venv install has to work on 64- and 32-bit Raspberry Pi OS: so for each
dependency PyPI must carry a pure-Python wheel or a binary wheel for that CPU. This asks pip to
resolve the project's dependencies for those platforms with ``--only-binary=:all:`` (PyPI only).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from packaging.requirements import Requirement

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

REPO_ROOT = Path(__file__).resolve().parents[2]
DEPENDENCIES = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
GLIBC_MINORS = range(17, 37)  # manylinux_2_17 ... 2_36 (Debian 12's glibc); pip does not widen the range itself


def dependencies_for(arch: str) -> list[str]:
    """The requirements that apply on ``arch`` (markers evaluated for that CPU), without their markers:
    pip evaluates markers against the machine it runs on, not the --platform it downloads for."""
    chosen = []
    for text in DEPENDENCIES:
        requirement = Requirement(text)
        env = {"platform_machine": arch, "python_version": "3.11", "sys_platform": "linux"}
        if requirement.marker is None or requirement.marker.evaluate(env):
            chosen.append(f"{requirement.name}{requirement.specifier}")
    return chosen


def _platform_args(arch: str) -> list[str]:
    tags = [f"manylinux_2_{minor}_{arch}" for minor in GLIBC_MINORS] + [f"manylinux2014_{arch}", f"linux_{arch}"]
    return [word for tag in tags for word in ("--platform", tag)]


@pytest.mark.timeout(900)
@pytest.mark.parametrize("arch", ["aarch64", "armv7l"])
def test_runtime_dependencies_have_wheels_for_raspberry_pi(arch: str, tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "pip", "download", "--disable-pip-version-check", "--only-binary=:all:",
         "--python-version", "3.11", "--implementation", "cp", *_platform_args(arch),
         "--dest", str(tmp_path), *dependencies_for(arch)],
        capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"no wheels for {arch}:\n{done.stdout[-2000:]}{done.stderr[-2000:]}"
    wheels = sorted(p.name for p in tmp_path.glob("*.whl"))
    assert any(name.startswith("falcon-") for name in wheels) and any(name.startswith("zeroconf-") for name in wheels)
