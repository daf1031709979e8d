"""A non-editable install (the README's ``pip install .``, the Dockerfile) carries every subpackage.

pyproject.toml names the packages one by one (so static/ can be mapped in as alpaca_zwo.static);
a subpackage missing from that list installs nothing and the server dies on import, which an
editable install (as in development) never shows. The README and container tests show it for
real; this check names the missing package in a second.
"""

from __future__ import annotations

import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

REPO_ROOT = Path(__file__).resolve().parents[2]


def test_every_subpackage_is_listed_in_pyproject() -> None:
    listed = set(tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    inits = (REPO_ROOT / "alpaca_zwo").rglob("__init__.py")
    on_disk = {".".join(init.parent.relative_to(REPO_ROOT).parts) for init in inits}
    assert on_disk - listed == set(), "subpackages missing from [tool.setuptools] packages in pyproject.toml"
