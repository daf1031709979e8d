"""The settings file on disk: where it lives, reading it with line-exact errors, writing it atomically.

``config`` defines and validates the settings; this module only moves them between a TOML file
and :class:`~alpaca_zwo.config.settings.Settings`.
"""

from __future__ import annotations

import contextlib
import os
import re
import stat
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import platformdirs
import tomli_w

from .._exceptions import ConfigError, ConfigWriteError
from .settings import Settings, assign_unique_ids, settings_from_dict, settings_to_dict, validate_settings

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised only on 3.10
    import tomli as tomllib

APP_NAME = "alpaca-zwo"
CONFIG_FILE_NAME = "config.toml"

_FILE_HEADER = (
    "# alpaca-zwo settings.\n"
    "# alpaca-zwo rewrites this file when it saves settings (first start, setup page), so comments\n"
    "# added here are not kept. Edit it while the server is stopped.\n\n"
)


def default_config_path() -> Path:
    """``config.toml`` in the per-user config directory (no vendor folder level on Windows)."""
    return Path(platformdirs.user_config_dir(APP_NAME, appauthor=False)) / CONFIG_FILE_NAME


_TOML_POSITION = re.compile(r"^(?P<reason>.*) \(at line (?P<line>\d+), column (?P<column>\d+)\)$", re.DOTALL)
_TOML_AT_END = re.compile(r"^(?P<reason>.*) \(at end of document\)$", re.DOTALL)


def _parse_toml(text: str, path: Path) -> dict[str, Any]:
    try:
        data: dict[str, Any] = tomllib.loads(text)
        return data
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        if match := _TOML_POSITION.match(message):
            line, column, reason = match["line"], match["column"], match["reason"]
        elif match := _TOML_AT_END.match(message):
            lines = text.split("\n")
            line, column, reason = (
                str(len(lines)),
                str(len(lines[-1]) + 1),
                match["reason"] + " at end of file",
            )
        else:
            raise ConfigError(f"{path}: invalid TOML: {message}") from None
        raise ConfigError(f"{path}: line {line}, column {column}: invalid TOML: {reason}") from None


def _read_settings_file(path: Path) -> dict[str, Any] | None:
    """The parsed file, or None if it does not exist."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    try:
        text = raw.decode("utf-8-sig")  # tolerate the BOM some Windows editors add
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (bad byte at offset {exc.start})") from None
    return _parse_toml(text, path)


def load_settings(path: Path | None = None) -> Settings:
    """Read settings from ``path`` (default: :func:`default_config_path`).

    A missing file yields the defaults. Devices without a UniqueID get one, and the file is then
    (re)written so the id survives restarts: clients key their profiles on it, so it must be
    generated exactly once. Raises ConfigError for anything wrong with the file.
    """
    path = Path(path) if path is not None else default_config_path()
    data = _read_settings_file(path)
    settings = settings_from_dict(data or {}, path)
    complete = assign_unique_ids(settings)
    if data is None or complete is not settings:
        save_settings(complete, path)
    return complete


def save_settings(settings: Settings, path: Path | None = None) -> None:
    """Validate and write ``settings`` atomically, readable only by the owner (it may hold a password).

    Atomic (temporary file in the same directory, then os.replace) so a crash or a full disk
    never leaves a half-written file that would stop the next start.
    """
    path = Path(path) if path is not None else default_config_path()
    validate_settings(settings, path)
    text = _FILE_HEADER + tomli_w.dumps(settings_to_dict(settings))
    tmp_name: str | None = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # The writer's pid in the name lets the next start tell an abandoned file from a live write.
        fd, tmp_name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp")  # 0600
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp_name, path)
        tmp_name = None
    except OSError as exc:
        # mkdir(exist_ok=True) says "File exists" when a file stands where the folder should be.
        reason = "its folder is a file" if isinstance(exc, FileExistsError) else exc.strerror or type(exc).__name__
        raise ConfigWriteError(f"{path}: cannot write: {reason}", reason) from exc
    finally:
        if tmp_name is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp_name)


#: A temporary file is abandoned once older than this, whoever wrote it (a save lasts milliseconds).
STALE_TEMP_AGE_S = 60.0


def remove_stale_temp_files(path: Path, now: float | None = None) -> list[Path]:
    """Delete the temporary files :func:`save_settings` left for ``path`` when killed mid-write.

    Only our own names (``.<file name>.[<pid>.]<random>.tmp``) in the file's folder, and only
    abandoned ones: written by a process that no longer exists (POSIX; on Windows a signal cannot
    probe a pid safely) or older than :data:`STALE_TEMP_AGE_S`. A second server saving the same
    file right now keeps its temporary file. Returns what was removed; errors are ignored (the
    files are harmless, only clutter).
    """
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(?:(?P<pid>\d+)\.)?[A-Za-z0-9_]+\.tmp$")
    now = time.time() if now is None else now
    removed = []
    try:
        entries = list(path.parent.iterdir())
    except OSError:
        return []
    for entry in entries:
        match = pattern.match(entry.name)
        if match is None:
            continue
        try:
            info = entry.lstat()
            if not stat.S_ISREG(info.st_mode):
                continue
            pid = match["pid"]
            if now - info.st_mtime > STALE_TEMP_AGE_S or (pid is not None and not _process_exists(int(pid))):
                entry.unlink()
                removed.append(entry)
        except OSError:
            continue
    return removed


def _process_exists(pid: int) -> bool:
    if os.name != "posix" or pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: it exists, someone else's
        return True
    return True
