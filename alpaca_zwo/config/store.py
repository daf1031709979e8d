"""The live settings: one thread-safe holder that persists every change it is given.

The Telescope (site, park position), the setup page (limits, safety) and the server all read
the same :class:`Settings`; changes are whole-value replacements saved atomically, so a reader
never sees half an update and a crash never leaves half a file.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from pathlib import Path

from .._exceptions import ConfigWriteError, SettingsNotSaved
from .file import save_settings
from .settings import Settings, validate_settings

log = logging.getLogger(__name__)


class SettingsStore:
    """Holds the current Settings; ``path=None`` keeps changes in memory only (tests, --no-save)."""

    def __init__(self, settings: Settings, path: Path | None = None) -> None:
        self._settings = settings
        self._path = path
        self._lock = threading.Lock()
        self._listeners: list[Callable[[Settings], None]] = []

    @property
    def settings(self) -> Settings:
        return self._settings

    @property
    def path(self) -> Path | None:
        return self._path

    def update(self, change: Callable[[Settings], Settings]) -> Settings:
        """Apply ``change`` to the current settings, validate, save, then tell the listeners.

        Save first, publish after: if the file cannot be written (full disk, read-only directory)
        SettingsNotSaved (an ASCOM DriverError) is raised and both the file and the live settings
        keep the old values, so callers that apply a change elsewhere (the mount) do so only after
        this returns. Its message carries the system's reason but never the file's path (it goes
        into HTTP replies); the log gets the path.
        """
        with self._lock:
            updated = change(self._settings)
            validate_settings(updated, "settings")  # a label, not the path: the message may reach a client
            if self._path is not None:
                try:
                    save_settings(updated, self._path)
                except ConfigWriteError as exc:
                    log.error("settings not saved: %s", exc)
                    raise SettingsNotSaved(f"the settings could not be saved ({exc.reason}): nothing was "
                                           "changed, the server and its settings file keep the previous "
                                           "values") from None
            self._settings = updated
            listeners = list(self._listeners)
        for listener in listeners:
            listener(updated)
        return updated

    def subscribe(self, listener: Callable[[Settings], None]) -> None:
        self._listeners.append(listener)
