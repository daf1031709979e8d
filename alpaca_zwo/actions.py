"""ZWO features beyond ITelescopeV4, served through Alpaca's Action() / SupportedActions.

(Work in progress: the table of actions is filled in by the following commits.)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ._exceptions import ActionNotImplemented

if TYPE_CHECKING:
    from .telescope import Telescope


def supported_actions() -> list[str]:
    """The action names SupportedActions lists."""
    return []


def run_action(telescope: Telescope, name: str, parameters: str) -> str:
    """Run one action by name (case-insensitive) and return its JSON reply."""
    raise ActionNotImplemented(f"action {name!r} is not supported")
