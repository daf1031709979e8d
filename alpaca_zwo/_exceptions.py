"""The one exception hierarchy of alpaca_zwo.

Every error the package raises on purpose derives from :class:`AlpacaZwoError`, so a caller can
catch "anything we meant" in one place and let genuine bugs surface as tracebacks. The ASCOM
error family lives here too (not in the HTTP layer) because the Telescope semantics below HTTP
decide which ASCOM code applies; the HTTP layer only renders them.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

# DriverError numbers (0x500..0xFFF), so scripts can tell the cases apart.
ERR_LINK = 0x500  # the mount link is down or failed
ERR_MOUNT_REFUSED = 0x501  # the mount answered eN# or a refusal byte
ERR_MOUNT_PROTOCOL = 0x502  # the mount's reply was garbled
ERR_TIMEOUT = 0x503  # the mount did not confirm or finish in time
ERR_INTERRUPTED = 0x504  # a synchronous slew was stopped or replaced by another client before it arrived
ERR_SETTINGS_NOT_SAVED = 0x510  # the settings file could not be written (disk full, read-only): nothing changed


class AlpacaZwoError(Exception):
    """Root of every error this package raises deliberately."""


class ProtocolError(AlpacaZwoError):
    """Raised when text on the mount line does not match the ZWO command language."""


class MountReplyError(AlpacaZwoError):
    """Raised when the mount refuses a command with an ``eN#`` code or a failure byte."""

    def __init__(self, request: str, reply: str, code: int | None = None, meaning: str = "") -> None:
        self.request = request
        self.reply = reply
        self.code = code
        self.meaning = meaning
        detail = f"e{code}: {meaning}" if code is not None else f"reply {reply!r}"
        super().__init__(f"mount refused {request}: {detail}")


class LinkError(AlpacaZwoError):
    """Raised when the byte pipe to the mount is closed, unplugged or unreachable."""


class LinkTimeout(LinkError):
    """Raised when the mount does not complete a reply within the link timeout."""


class AmbiguousReply(ProtocolError):
    """Raised when a reply is not exactly one known form (junk around it): the outcome is unknown."""


class MotionCancelled(AlpacaZwoError):
    """Raised when a motion command is withdrawn unsent because a stop arrived first."""


class ConfigError(AlpacaZwoError):
    """Raised when a configuration file or command-line value is invalid; names file, key and reason."""


class ConfigWriteError(ConfigError):
    """Raised when the settings file cannot be written (full disk, read-only or missing directory).

    The message names the file (for the log and the command line); ``reason`` is the operating
    system's words alone, which is all an HTTP reply may repeat.
    """

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason


class AlpacaError(AlpacaZwoError):
    """Raised for an ASCOM-level failure; rendered as HTTP 200 with ErrorNumber/ErrorMessage."""

    number: int = 0x500

    def __init__(self, message: str, number: int | None = None) -> None:
        if number is not None:
            self.number = number
        self.message = message
        super().__init__(message)


class MemberNotImplemented(AlpacaError):
    """Raised when the mount lacks the capability a member needs (ASCOM 0x400)."""

    number = 0x400


class InvalidValue(AlpacaError):
    """Raised when a well-formed value is out of range or not allowed (ASCOM 0x401)."""

    number = 0x401


class ValueNotSet(AlpacaError):
    """Raised when a value is read before it was ever written, e.g. the targets (ASCOM 0x402)."""

    number = 0x402


class NotConnected(AlpacaError):
    """Raised when a member needs the device connected and it is not (ASCOM 0x407)."""

    number = 0x407


class Parked(AlpacaError):
    """Raised when a motion, sync or tracking request arrives while the mount is parked (ASCOM 0x408)."""

    number = 0x408


class InvalidOperation(AlpacaError):
    """Raised when a request is valid but not allowed in the current state (ASCOM 0x40B)."""

    number = 0x40B


class SafetyRefusal(InvalidOperation):
    """A motion refused because the observatory's safety monitor (or roof) says it is not safe (ASCOM 0x40B).

    A subclass so that the bridges can answer it as the mount answers a refusal, distinct from "busy"."""


class ActionNotImplemented(AlpacaError):
    """Raised when Action() names an action this driver does not support (ASCOM 0x40C)."""

    number = 0x40C


class DriverError(AlpacaError):
    """Raised when the mount or its link failed to carry out a request (ASCOM 0x500 and up)."""

    number = 0x500


class SettingsNotSaved(DriverError):
    """Raised when a change could not be saved: the running server and the file both kept the old values."""

    number = ERR_SETTINGS_NOT_SAVED


#: The one table of the mount's ``eN#`` refusals as a client is told them: the ASCOM error and plain words
#: that say what to do. The codes are the vendor's v1.7 table, confirmed on the wire for 2, 6, 7, 11 and 14
#: (real-transcripts-1.8.8.md §2 item 10: ``e7#`` from an unsynchronised AM3 and AM5, ``e6#`` at ~9°
#: altitude, ``e2#`` for ``:Sd`` with 60 seconds, ``e9``/``e11``/``e12`` for ``:CM#`` across the meridian, at
#: home and over 20° away, ``e14#`` to every motion
#: while parked). ``{request}`` is the command the mount refused. Codes not listed stay a DriverError
#: (ERR_MOUNT_REFUSED) with the mount's meaning; 3 and 4 ("busy") are worded by :func:`_busy_words`.
MOUNT_REFUSALS: dict[int, tuple[type[AlpacaError], str]] = {
    2: (InvalidValue, "the mount rejected {request} as malformed (e2): a value it cannot take, or a server bug "
                      "worth reporting with the log"),
    5: (InvalidValue, "the target is below the horizon (e5)"),
    6: (InvalidValue, "the target is outside the mount's altitude limits (e6): below its lower limit or above its "
                      "upper limit (the setup page shows them)"),
    7: (InvalidOperation, "the mount's time and site are not set (e7): disconnect and connect again so the server "
                          "sends them, or check the site on the setup page"),
    11: (InvalidOperation, "the mount refuses a sync at its home position (e11): slew or move away from home "
                           "first, then sync"),
    9: (InvalidOperation, "the mount refuses a sync on a point across the meridian from where it points (e9): "
                          "a sync is for a star the telescope is centred on; GoTo the star, centre it, then sync"),
    12: (InvalidOperation, "the mount refuses a sync more than 20° from where it points (e12): a sync is for a "
                           "star the telescope is centred on; GoTo the star, centre it, then sync"),
    14: (Parked, "the mount is parked by its own firmware (e14; the ZWO app, ASIAIR or a hand controller parks "
                 "it so, and the park survives power cycles): Unpark first"),
}
_BUSY_CODES = (3, 4)


def _busy_words(code: int, moving: bool | None) -> str:
    """"The mount is moving" only when it is: a ZWO mount also answers busy while braking, and older
    firmware (and this project's emulator before 1.8.8 was modelled) answered a parked mount so."""
    if moving:
        return f"the mount is moving (e{code}): wait until Slewing is false, or AbortSlew"
    return (f"the mount answered busy (e{code}) although no motion is seen: it may still be braking, or be "
            "parked by its own firmware; check Slewing and AtPark and try again")


def driver_error(what: str, exc: Exception, moving: bool | None = None) -> AlpacaError:
    """The error a client sees for a link or mount failure during ``what`` (one wording for all).

    A mount refusal becomes the ASCOM error its code means (:data:`MOUNT_REFUSALS`); ``moving``: whether
    the caller sees the mount move, which decides the words of a "busy" refusal (None: unknown)."""
    if isinstance(exc, MountReplyError):
        return refusal_error(what, exc, moving)
    if isinstance(exc, ProtocolError):
        return DriverError(f"{what}: garbled reply from the mount: {exc}", ERR_MOUNT_PROTOCOL)
    return DriverError(f"{what}: mount link problem: {exc}", ERR_LINK)


def refusal_error(what: str, exc: MountReplyError, moving: bool | None = None) -> AlpacaError:
    """A mount refusal in the client's terms: the table's ASCOM error and words, else a DriverError."""
    code = exc.code
    if code in MOUNT_REFUSALS:
        error, words = MOUNT_REFUSALS[code]
        return error(f"{what}: {words.format(request=exc.request)}")
    if code in _BUSY_CODES:
        return InvalidOperation(f"{what}: {_busy_words(code, moving)}")
    return DriverError(f"{what}: the mount refused: {exc.meaning or exc.reply}", ERR_MOUNT_REFUSED)


@contextmanager
def mount_errors(what: str, moving: bool | None = None) -> Iterator[None]:
    """Within the block, link and mount failures become :func:`driver_error`'s errors."""
    try:
        yield
    except (MountReplyError, ProtocolError, LinkError) as exc:
        raise driver_error(what, exc, moving) from exc
