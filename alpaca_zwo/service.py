"""Start at boot: the systemd unit, launchd plist or Windows task for *this* install.

``alpaca-zwo --print-service systemd`` writes a unit whose ExecStart is the interpreter that is
running now (``<venv>/bin/python -m alpaca_zwo``), so it follows whatever the README's install
made, with no path to edit by hand. The same options that would be given to the server
(``--device auto``, ``--port`` ...) are carried into the service's command line.
"""

from __future__ import annotations

import getpass
import os
import plistlib
import sys
from pathlib import Path

__all__ = ["KINDS", "launchd_plist", "render", "server_command", "systemd_unit", "windows_task"]

KINDS = ("systemd", "launchd", "windows")
LAUNCHD_LABEL = "local.alpaca-zwo"


def server_command(args: list[str], *, windowless: bool = False) -> list[str]:
    """The command that starts this install's server with ``args``.

    The interpreter's path is kept as it is (not resolved): a venv's ``bin/python`` is a symlink,
    and resolving it would escape the venv and lose its packages.
    """
    python = os.path.abspath(sys.executable)
    if windowless:  # pythonw.exe runs without a console window on Windows
        candidate = Path(python).with_name("pythonw.exe")
        if candidate.exists():
            python = str(candidate)
    return [python, "-m", "alpaca_zwo", *args]


def _systemd_quote(word: str) -> str:
    """One ExecStart word: quoted when needed; ``%`` and ``$`` escaped (systemd specifiers and variables)."""
    word = word.replace("%", "%%").replace("$", "$$")
    if word and not any(ch in word for ch in ' \t"\'\\;'):
        return word
    return '"' + word.replace("\\", "\\\\").replace('"', '\\"') + '"'


def systemd_unit(args: list[str], user: str | None = None) -> str:
    """A system unit running as ``user`` (the one who asked), with the serial ports' group."""
    user = user or getpass.getuser()
    exec_start = " ".join(_systemd_quote(word) for word in server_command(args))
    user_lines = "" if user == "root" else f"User={user}\nSupplementaryGroups=dialout\n"
    return f"""# alpaca-zwo, made by `alpaca-zwo --print-service systemd` for this install. Install and start:
#   alpaca-zwo --print-service systemd ... | sudo tee /etc/systemd/system/alpaca-zwo.service
#   sudo systemctl daemon-reload && sudo systemctl enable --now alpaca-zwo
[Unit]
Description=alpaca-zwo ASCOM Alpaca server for ZWO AM mounts
Wants=network-online.target
After=network-online.target

[Service]
Type=simple
{user_lines}ExecStart={exec_start}
# SIGTERM stops any manual motion (and parks if safety.on_shutdown = "park") before exiting.
KillSignal=SIGTERM
TimeoutStopSec=150
# Descriptors for waitress's 1000 connections (64 per address, server.max_connections_per_address),
# the bridges, the serial port and logs; the usual default soft limit (1024) is too tight.
LimitNOFILE=4096
# A mount that is not switched on yet, or a crash: try again (the server exits 0 only when stopped).
Restart=on-failure
RestartSec=5

[Install]
WantedBy=multi-user.target
"""


def launchd_plist(args: list[str]) -> str:
    """A per-user LaunchAgent: starts at login, restarted when it fails."""
    logs = Path.home() / "Library" / "Logs" / "alpaca-zwo.log"
    plist = {
        "Label": LAUNCHD_LABEL,
        "ProgramArguments": server_command(args),
        "RunAtLoad": True,
        "KeepAlive": {"SuccessfulExit": False},
        "ThrottleInterval": 5,
        "StandardOutPath": str(logs),
        "StandardErrorPath": str(logs),
    }
    return plistlib.dumps(plist).decode()


def _ps_quote(word: str) -> str:
    return "'" + word.replace("'", "''") + "'"


def windows_task(args: list[str]) -> str:
    """PowerShell that registers a Task Scheduler task: at logon, no console, restarted on failure."""
    command = server_command(args, windowless=True)
    arguments = " ".join(f'"{a}"' if " " in a else a for a in command[1:])
    return "\n".join([
        "# Run in PowerShell (as the user who will run the server):",
        f"$action = New-ScheduledTaskAction -Execute {_ps_quote(command[0])} -Argument {_ps_quote(arguments)}",
        "$trigger = New-ScheduledTaskTrigger -AtLogOn -User $env:USERNAME",
        "$settings = New-ScheduledTaskSettingsSet -RestartCount 999 -RestartInterval (New-TimeSpan -Minutes 1) "
        "-ExecutionTimeLimit ([TimeSpan]::Zero) -AllowStartIfOnBatteries -DontStopIfGoingOnBatteries",
        "Register-ScheduledTask -TaskName alpaca-zwo -Action $action -Trigger $trigger -Settings $settings",
        "Start-ScheduledTask -TaskName alpaca-zwo",
        "",
    ])


def render(kind: str, args: list[str]) -> str:
    if kind == "systemd":
        return systemd_unit(args)
    if kind == "launchd":
        return launchd_plist(args)
    return windows_task(args)
