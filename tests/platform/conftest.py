"""Platform tests: root-only tests report "not run, needs root" for a developer, and fail under CI.

CI runs as root and must run every one of them: a skipped root-only test there would hide a
broken README, container or boot unit behind a green run, so with ``CI=true`` it fails instead.
"""

from __future__ import annotations

import os

import pytest

NEEDS_ROOT = "not run, needs root (debootstrap, chroot, ip netns, private podman storage)"


def in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


def require_root() -> None:
    """Skip with the reason for a developer, fail in CI, unless this run is root."""
    if os.geteuid() == 0:
        return
    if in_ci():
        pytest.fail(f"CI must run every root-only test, but this run is not root: {NEEDS_ROOT}")
    pytest.skip(NEEDS_ROOT)


@pytest.fixture
def root_only() -> None:
    """Use on every test that needs root (before any fixture that does root-only work)."""
    require_root()
