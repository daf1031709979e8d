"""Cutting the request byte stream into command bodies, the way the mount does.

Why not ``protocol.RequestFramer``: it treats EVERY ``:`` as the start of a new command, but
arguments contain colons (``:SL22:05:09#``, ``:Sr12:34:56#``, ``:Sd+45*30:15#``), so it cuts
them into fragments and the mount would never answer a time or target setter. The mount must
tell the two apart, and only one rule fits both the arguments and INDI's unterminated
``:Rg0.30`` glued to ``:GU#`` (field notes §8): a ``:`` inside a command starts a new command
only when a LETTER follows it (every command code begins with a letter; every colon inside an
argument is followed by a digit). The decision waits for that next byte, which is fine because
a command is acted on only at its ``#`` anyway.
"""

from __future__ import annotations

__all__ = ["MountFramer"]


class MountFramer:
    """Incremental framer: ``feed(bytes)`` returns the bodies (text between ``:`` and ``#``)
    completed by those bytes. Bytes outside a command (stray ``#``, CR/LF, an LX200 ACK) are
    ignored; an abandoned fragment or a body longer than the mount's 62 characters is dropped.
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
                if ("A" <= char <= "Z") or ("a" <= char <= "z"):
                    self.dropped += 1  # the fragment before it was never terminated
                    self._body = [char]
                    continue
                if char == ":":
                    self.dropped += 1
                    self._body = []
                    continue
                self._append(":")
                if self._body is None:
                    continue
            if char == ":":
                self._colon = True
            elif char == "#":
                bodies.append("".join(self._body))
                self._body = None
            else:
                self._append(char)
        return bodies

    def _append(self, char: str) -> None:
        assert self._body is not None
        if len(self._body) >= self.MAX_LENGTH:
            self._body = None  # a runaway command: the mount discards it
            self.dropped += 1
            return
        self._body.append(char)
