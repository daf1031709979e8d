"""The mount's side of the ZWO protocol: one request body in, the reply a real mount sends out.

One table, ``protocol.COMMANDS``: each command's row parses its argument, says what it asks of the
mount (``Command.asks``, a call on a ``protocol.Backend``) and formats the reply; a backend is the mount
that answers. Two backends serve it: the emulator's (``emulator/responder.py``: the modelled mount,
with its firmware's quirks) and the shared ZWO port's (``bridges/zwo_backend.py``: the Telescope,
answering from its snapshots, refusing what changes the mount for every program). Where they answer
differently, the backend says so; the table is the same.

The rules every answer follows (field notes §2-§4): a request the mount does not know (an unknown or
miscased code) gets no reply; a known command whose arguments are malformed, or whose values do not
parse, gets its row's refusal (``Command.refused``: a setter's bare ``0``, ``e2#`` for a target, a
GOTO's ``e2#``) without reaching the backend; otherwise the backend acts and its value is framed
by the row (a setter's bare ``1``/``0``, a GOTO's bare ``0`` or ``eN#``, ``#``-terminated queries,
silence for motion).
"""

from __future__ import annotations

from typing import Any

from .._exceptions import AlpacaZwoError, ProtocolError
from .protocol import COMMANDS, Backend, Verbatim, match_command

__all__ = ["Backend", "NoReply", "Refusal", "Verbatim", "answer"]


class NoReply(AlpacaZwoError):
    """Raised by a backend that has nothing to say (no reading yet, the mount unreachable): no reply,
    as from a mount that is not there."""


class Refusal(AlpacaZwoError):
    """Raised by a backend that refuses a command: ``value`` is the reply value the mount gives that
    refusal (formatted by the command's row: a bare ``0``, ``e3#`` …), ``reason`` says why. The
    dispatcher fills in ``reply``, the text, and raises it on, so the shared port can count it."""

    def __init__(self, value: Any, reason: str) -> None:
        super().__init__(reason)
        self.value = value
        self.reason = reason
        self.reply: str | None = None


_unasked = [command.code for command in COMMANDS if command.asks is None]
if _unasked:  # a row that asks nothing of the mount would go silent: fail at import instead
    raise RuntimeError(f"protocol.COMMANDS rows without asks: {_unasked}")


def answer(backend: Backend, body: str) -> str | None:
    """The reply text for request ``body`` (the text between ``:`` and ``#``), None for silence.

    Raises :class:`Refusal` (with ``reply`` filled in) when the backend refused the command.
    """
    match = match_command(body)
    if match is None:
        return None  # unknown or miscased: a real mount stays silent
    command = match.command
    try:
        own = backend.intercept(match)
        if own is not None:
            return own.reply
        argument = None
        if command.argument is not None:
            if not match.well_formed:
                return command.reply_text(command.refused)
            try:
                argument = command.argument.parse(match.argument)
            except (ProtocolError, ValueError):
                return command.reply_text(command.refused)
        assert command.asks is not None  # checked for every row at import
        return command.reply_text(command.asks(backend, argument))
    except NoReply:
        return None
    except Refusal as refusal:
        refusal.reply = command.reply_text(refusal.value)
        raise
