"""Cutting a request byte stream into ZWO command bodies, as the mount's firmware does.

Used by everything that listens like a mount: the emulator and the ZWO serial-port bridge.
"""

from __future__ import annotations


class RequestFramer:
    """Cuts a request byte stream into command bodies (text between ``:`` and ``#``) as the mount does.

    Arguments contain colons (``:SL22:05:09#``, ``:Sd+45*30:15#``), yet INDI sends ``:Rg0.30``
    without its ``#`` glued to the next ``:GU#`` (field notes §8), and that fragment must not
    swallow the poll. One rule fits both: a ``:`` inside a command starts a new command only when a
    letter follows it (every code begins with a letter; every colon inside an argument is followed
    by a digit). Bytes outside a command (stray ``#``, CR/LF, an LX200 ACK) are ignored; a body
    longer than the mount's 62-character limit is dropped.
    """

    MAX_LENGTH = 62

    def __init__(self) -> None:
        self._body: list[str] | None = None
        self._colon = False  # a ':' inside a body, waiting for the next byte to decide its role
        self.dropped = 0

    def feed(self, data: bytes) -> list[str]:
        bodies: list[str] = []
        for char in data.decode("latin-1"):
            if self._body is None:
                if char == ":":
                    self._body = []
                continue
            if self._colon:
                self._colon = False
                if char.isascii() and char.isalpha():
                    self.dropped += 1  # the fragment before it was never terminated
                    self._body = [char]
                    continue
                if char == ":":
                    self.dropped += 1
                    self._body = []
                    continue
                if not self._append(":"):
                    continue
            if char == ":":
                self._colon = True
            elif char == "#":
                bodies.append("".join(self._body))
                self._body = None
            else:
                self._append(char)
        return bodies

    def _append(self, char: str) -> bool:
        """Add ``char`` to the open body; False when that made it too long and it was dropped."""
        assert self._body is not None
        if len(self._body) >= self.MAX_LENGTH:
            self._body = None  # a runaway command: the mount discards it
            self.dropped += 1
            return False
        self._body.append(char)
        return True
