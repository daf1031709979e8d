"""The Telescope's raw commands: CommandBlind, CommandBool and CommandString, and the shared ZWO
port's relay.

Off unless ``server.allow_raw_commands`` is set, because a raw command bypasses every safety check
(horizon, limits, the observatory interlock, the motion supervisor's bookkeeping). The relay has its
own switch: the shared port sends only the commands ``zwo_port.allow_dangerous`` lets through.
"""

from __future__ import annotations

from collections.abc import Callable

from .._exceptions import ERR_MOUNT_PROTOCOL, DriverError, MemberNotImplemented, mount_errors
from ..config.settings import Settings
from ..mount.operations import Mount


class RawCommands:
    """A command string sent to the mount as it is; ``require_connected`` is the owner's connection check."""

    def __init__(self, *, mount: Mount, settings: Callable[[], Settings],
                 require_connected: Callable[[], None]) -> None:
        self.mount = mount
        self._settings = settings
        self._require_connected = require_connected

    def _send(self, command: str) -> str:
        if not self._settings().server.allow_raw_commands:
            raise MemberNotImplemented(
                "raw mount commands are disabled (they bypass every safety check); "
                "set server.allow_raw_commands = true to enable them"
            )
        self._require_connected()
        with mount_errors("raw command"):
            return self.mount.raw(command)

    def command_blind(self, command: str, raw: bool) -> None:
        self._send(command)

    def command_bool(self, command: str, raw: bool) -> bool:
        reply = self._send(command).rstrip("#")
        if reply not in ("0", "1"):
            raise DriverError(f"mount replied {reply!r}, not a boolean", ERR_MOUNT_PROTOCOL)
        return reply == "1"

    def command_string(self, command: str, raw: bool) -> str:
        return self._send(command).rstrip("#")

    def relay(self, command: str) -> str:
        """Send ``command`` (``:XX…#``) as it is and return the mount's raw reply: a command that changes
        the mount for every program, which the server's owner let the shared ZWO port pass
        (``zwo_port.allow_dangerous``, checked by the port). The Mount marks what it changes (stored
        settings, readings) as after any command; a link failure raises, and the port stays silent."""
        return self.mount.raw(command)
