"""The client side of the mini-ConformU: ASCOM exceptions, the emulated "PC clock", and two clients.

``AlpacaTelescope`` re-implements what ConformU's own client (ASCOM Library ``AlpacaTelescope`` /
``RemoteDevice``, checklist §1) puts on the wire and how it reads the reply, because that is what
decides how a server's answer is graded: lower-case URLs, ``ClientID=1`` and an incrementing
``ClientTransactionID``, booleans as ``True``/``False`` and doubles in .NET round-trip form,
``UTCDate`` with seven fractional digits and ``Z``, a 2xx reply that must carry ``application/json``,
case-sensitive JSON keys, "error" meaning ``ErrorMessage != ""`` or ``ErrorNumber != 0``, the
error-number -> exception table, any non-2xx status as a ``DriverException``, and a ``UTCDate``
that must come back as a UTC (``Z``) date.

``AlpycaTelescope`` routes a part of the run through the ASCOM Initiative's official Python client
(alpyca), so the server is also exercised by client code nobody here wrote. alpyca itself is
lenient (no Content-Type check, ``ErrorMessage`` ignored when ``ErrorNumber`` is 0), so a response
hook on its ``requests`` session applies the same reply rules as ConformU's client, and alpyca's
exceptions are translated into the classes below: a reply is graded identically whichever client
carried it.

Time: every duration ConformU measures or waits out is on :class:`EmulatedClock`, the emulator's
clock (see the package docstring of ``test_conformu.py``).
"""

from __future__ import annotations

import contextlib
import json
import math
import re
import threading
import time
from collections.abc import Iterator
from datetime import datetime, timedelta, timezone
from typing import Any, Protocol

import requests

# --- ASCOM exceptions (ASCOM.Exceptions as the .NET client throws them) --------------------------


class AscomException(Exception):
    """Base of everything the ASCOM client can throw for a device reply."""

    def __init__(self, message: str = "") -> None:
        super().__init__(message)
        self.message = message


class DriverException(AscomException):
    """``ASCOM.DriverException``: ``number`` is the COM-style HRESULT (0x80040000 + Alpaca number)."""

    default_number = 0x80040500

    def __init__(self, message: str = "", number: int | None = None) -> None:
        super().__init__(message)
        self.number = self.default_number if number is None else number


class NotImplementedException(DriverException):
    default_number = 0x80040400


class InvalidValueException(DriverException):
    default_number = 0x80040401


class ValueNotSetException(DriverException):
    default_number = 0x80040402


class NotConnectedException(DriverException):
    default_number = 0x80040407


class ParkedException(DriverException):
    default_number = 0x80040408


class SlavedException(DriverException):
    default_number = 0x80040409


class InvalidOperationException(DriverException):
    default_number = 0x8004040B


class ActionNotImplementedException(DriverException):
    default_number = 0x8004040C


class OperationCancelledException(DriverException):
    default_number = 0x8004040E


class InvalidJsonDateTimeException(AscomException):
    """The client's ``throwOnBadDateTimeJson``: a date-time whose ``Kind`` is not UTC (no ``Z``)."""


class JsonException(Exception):
    """``System.Text.Json.JsonException``: a reply the typed deserialiser cannot read."""


class ConformTimeout(Exception):
    """``System.TimeoutException``: an HTTP timeout in the client, or a ConformU ``WaitWhile`` timeout."""


#: RemoteDevice's error-number table (checklist §1, RD L780-L842).
ERROR_CLASSES: dict[int, type[DriverException]] = {
    0x400: NotImplementedException,
    0x401: InvalidValueException,
    0x402: ValueNotSetException,
    0x407: NotConnectedException,
    0x408: ParkedException,
    0x409: SlavedException,
    0x40B: InvalidOperationException,
    0x40C: ActionNotImplementedException,
    0x40E: OperationCancelledException,
}

#: ASCOM ErrorCodes values ConformU compares exception numbers with.
INVALID_VALUE = 0x80040401
INVALID_OPERATION = 0x8004040B


def exception_for(number: int, message: str) -> DriverException:
    """The exception the ASCOM client throws for a JSON error reply."""
    cls = ERROR_CLASSES.get(number)
    if cls is not None:
        return cls(message)
    if 0x400 <= number <= 0xFFF:
        return DriverException(message, 0x80040000 + number)
    return DriverException(message, number)


def exception_name(ex: BaseException) -> str:
    """ConformU's GetExceptionName: DriverException gets its number, other ASCOM types their name."""
    if type(ex) is DriverException:
        return f"DriverException(0x{ex.number & 0xFFFFFFFF:08X})"
    if isinstance(ex, AscomException):
        return type(ex).__name__
    return f"{type(ex).__name__} exception"


# --- .NET value formatting ------------------------------------------------------------------------


def dotnet_double(value: float) -> str:
    """``Convert.ToString(double, InvariantCulture)``: shortest round-trip, ``1E-05`` exponents, no ``.0``."""
    if not math.isfinite(value):
        return {math.inf: "∞", -math.inf: "-∞"}.get(value, "NaN")
    text = repr(float(value))
    if "e" in text:
        mantissa, exponent = text.split("e")
        if mantissa.endswith(".0"):
            mantissa = mantissa[:-2]
        sign = "-" if exponent.startswith("-") else "+"
        return f"{mantissa}E{sign}{int(exponent.lstrip('+-')):02d}"
    return text[:-2] if text.endswith(".0") else text


def dotnet_value(value: object) -> str:
    """How the ASCOM client writes a PUT parameter value (RD ``SetValue``)."""
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return dotnet_double(value)
    if isinstance(value, datetime):
        return utc_date_text(value)
    return str(value)


def utc_date_text(value: datetime) -> str:
    """``value.ToString("yyyy-MM-ddTHH:mm:ss.fffffff") + "Z"`` (ATEL L856-L861)."""
    d = value.astimezone(timezone.utc) if value.tzinfo else value
    return f"{d:%Y-%m-%dT%H:%M:%S}.{d.microsecond:06d}0Z"


_ISO_DATE = re.compile(
    r"(\d{4})-(\d{2})-(\d{2})T(\d{2}):(\d{2}):(\d{2})(?:\.(\d{1,7}))?(Z|[+-]\d{2}:\d{2})?"
)


def parse_utc_date(text: object) -> datetime:
    """The client's DateTime read with ``throwOnBadDateTimeJson=true``: only a ``Z`` date is UTC."""
    if not isinstance(text, str):
        raise JsonException(f"UTCDate value {text!r} is not a JSON string")
    match = _ISO_DATE.fullmatch(text)
    if match is None:
        raise JsonException(f"UTCDate value {text!r} is not an ISO 8601 date-time")
    year, month, day, hour, minute, second, fraction, zone = match.groups()
    if zone != "Z":
        raise InvalidJsonDateTimeException(
            f"The UTCDate value {text!r} is not a UTC date-time (it has no 'Z' designator)")
    micro = int((fraction or "0").ljust(7, "0")[:6])
    return datetime(int(year), int(month), int(day), int(hour), int(minute), int(second), micro,
                    tzinfo=timezone.utc)


# --- time -------------------------------------------------------------------------------------------


class ClockSource(Protocol):
    speed: float

    def now(self) -> datetime: ...

    def seconds(self) -> float: ...


class EmulatedClock:
    """ConformU's "PC clock" and stopwatch, run on the emulator's (possibly fast) clock.

    ``DateTime.UtcNow``, ``Stopwatch`` and ``Thread.Sleep`` in ConformU all map to this clock, so a
    5 s WaitForSlew minimum or a 2 s MoveAxis run lasts 5 or 2 *mount* seconds, which is 5/speed or
    2/speed real seconds.
    """

    def __init__(self, source: ClockSource) -> None:
        self._source = source
        self.speed = float(source.speed)

    def utcnow(self) -> datetime:
        return self._source.now()

    def seconds(self) -> float:
        return self._source.seconds()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds / self.speed)

    def real(self, seconds: float) -> float:
        """Real seconds for an emulated duration (HTTP timeouts)."""
        return seconds / self.speed


class Stopwatch:
    """``System.Diagnostics.Stopwatch`` on the emulated clock."""

    def __init__(self, clock: EmulatedClock) -> None:
        self._clock = clock
        self._start = clock.seconds()

    @property
    def elapsed(self) -> float:
        return self._clock.seconds() - self._start


# --- the ConformU client ------------------------------------------------------------------------------

#: Real-time floor under every scaled HTTP timeout, so a loaded machine's scheduling jitter is not
#: mistaken for a hung device (the timeouts only guard against hangs; no check depends on them).
MIN_REAL_TIMEOUT_S = 2.0

TimedCall = tuple[str, float, str]  # (member, real seconds, "GET"/"PUT")


def _typed(value: object, kind: str) -> object:
    """The typed ``Value`` as System.Text.Json would produce it, or JsonException."""
    if kind == "bool":
        if isinstance(value, bool):
            return value
    elif kind == "double":
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
    elif kind == "int":
        if isinstance(value, int) and not isinstance(value, bool):
            return value
    elif kind == "str":
        if value is None or isinstance(value, str):
            return value
    elif kind == "list":
        if isinstance(value, list):
            return value
    elif kind == "date":
        return parse_utc_date(value)
    raise JsonException(f"The JSON value {value!r} could not be converted to {kind}")


_DEFAULTS: dict[str, object] = {"bool": False, "double": 0.0, "int": 0, "str": None, "list": None}


class _Prop:
    """A telescope property on the wire: GET <name>, PUT <name> with a form field of the same name."""

    def __init__(self, name: str, kind: str, *, writable: bool = False, timeout: str = "standard") -> None:
        self.name = name
        self.kind = kind
        self.writable = writable
        self.timeout = timeout

    def __get__(self, obj: AlpacaTelescope | None, owner: type) -> Any:
        if obj is None:
            return self
        return obj.get_value(self.name, self.kind)

    def __set__(self, obj: AlpacaTelescope, value: object) -> None:
        if not self.writable:
            raise AttributeError(f"{self.name} is read-only")
        obj.put(self.name, [(self.name, dotnet_value(value))], timeout=self.timeout)


class AlpacaTelescope:
    """ConformU's ``AlpacaTelescope`` client (ATEL/RD), property for property and method for method."""

    def __init__(self, host: str, port: int, device_number: int, clock: EmulatedClock, *, client_id: int = 1,
                 establish_timeout: float = 5.0, standard_timeout: float = 10.0, long_timeout: float = 100.0,
                 user_agent: str = "ConformUniversal/4.4.0") -> None:
        # RD L570: the whole URL, host included, is lower-cased.
        self.base_url = f"http://{host}:{port}/api/v1/telescope/{device_number}/".lower()
        self.clock = clock
        self.client_id = client_id
        self._timeouts = {"standard": standard_timeout, "long": long_timeout}
        self._establish = establish_timeout
        self._session = requests.Session()
        self._session.headers.update({"User-Agent": user_agent, "Accept": "application/json"})
        self._ctid = 0
        self._lock = threading.Lock()
        #: (member, real seconds, verb) of every call, for the timing summary.
        self.calls: list[TimedCall] = []

    def close(self) -> None:
        self._session.close()

    def _next_ctid(self) -> int:
        with self._lock:
            self._ctid += 1
            return self._ctid

    def _timeout(self, which: str) -> tuple[float, float]:
        return (max(self.clock.real(self._establish), MIN_REAL_TIMEOUT_S),
                max(self.clock.real(self._timeouts[which]), MIN_REAL_TIMEOUT_S))

    def _send(self, verb: str, member: str, params: list[tuple[str, str]], timeout: str) -> dict[str, Any]:
        url = self.base_url + member.lower()
        ids = [("ClientID", str(self.client_id)), ("ClientTransactionID", str(self._next_ctid()))]
        started = time.monotonic()
        try:
            if verb == "GET":
                response = self._session.get(url, params=ids + params, timeout=self._timeout(timeout))
            else:
                response = self._session.put(url, data=params + ids, timeout=self._timeout(timeout))
        except requests.Timeout as exc:
            raise ConformTimeout(f"{verb} {member}: no reply within the client timeout ({exc})") from exc
        except requests.RequestException as exc:
            raise DriverException(f"Error calling p.Method: {member}: {exc}") from exc
        finally:
            self.calls.append((member, time.monotonic() - started, verb))
        return check_reply(member, response)

    def get_value(self, member: str, kind: str, params: list[tuple[str, str]] | None = None) -> Any:
        body = self._send("GET", member, params or [], "standard")
        if "Value" not in body:  # a missing (or miscased) "Value" deserialises as the type's default
            if kind == "date":
                return parse_utc_date(None)
            return _DEFAULTS[kind]
        return _typed(body["Value"], kind)

    def put(self, member: str, params: list[tuple[str, str]], timeout: str = "standard") -> dict[str, Any]:
        return self._send("PUT", member, params, timeout)

    # -- common members ----------------------------------------------------------------------------
    Connected = _Prop("Connected", "bool", writable=True)
    Connecting = _Prop("Connecting", "bool")
    Description = _Prop("Description", "str")
    DriverInfo = _Prop("DriverInfo", "str")
    DriverVersion = _Prop("DriverVersion", "str")
    InterfaceVersion = _Prop("InterfaceVersion", "int")
    Name = _Prop("Name", "str")
    SupportedActions = _Prop("SupportedActions", "list")
    DeviceState = _Prop("DeviceState", "list")

    def Connect(self) -> None:
        self.put("Connect", [])

    def Disconnect(self) -> None:
        self.put("Disconnect", [])

    # -- telescope properties ------------------------------------------------------------------------
    AlignmentMode = _Prop("AlignmentMode", "int")
    Altitude = _Prop("Altitude", "double")
    ApertureArea = _Prop("ApertureArea", "double")
    ApertureDiameter = _Prop("ApertureDiameter", "double")
    AtHome = _Prop("AtHome", "bool")
    AtPark = _Prop("AtPark", "bool")
    Azimuth = _Prop("Azimuth", "double")
    CanFindHome = _Prop("CanFindHome", "bool")
    CanPark = _Prop("CanPark", "bool")
    CanPulseGuide = _Prop("CanPulseGuide", "bool")
    CanSetDeclinationRate = _Prop("CanSetDeclinationRate", "bool")
    CanSetGuideRates = _Prop("CanSetGuideRates", "bool")
    CanSetPark = _Prop("CanSetPark", "bool")
    CanSetPierSide = _Prop("CanSetPierSide", "bool")
    CanSetRightAscensionRate = _Prop("CanSetRightAscensionRate", "bool")
    CanSetTracking = _Prop("CanSetTracking", "bool")
    CanSlew = _Prop("CanSlew", "bool")
    CanSlewAltAz = _Prop("CanSlewAltAz", "bool")
    CanSlewAltAzAsync = _Prop("CanSlewAltAzAsync", "bool")
    CanSlewAsync = _Prop("CanSlewAsync", "bool")
    CanSync = _Prop("CanSync", "bool")
    CanSyncAltAz = _Prop("CanSyncAltAz", "bool")
    CanUnpark = _Prop("CanUnpark", "bool")
    Declination = _Prop("Declination", "double")
    DeclinationRate = _Prop("DeclinationRate", "double", writable=True)
    DoesRefraction = _Prop("DoesRefraction", "bool", writable=True)
    EquatorialSystem = _Prop("EquatorialSystem", "int")
    FocalLength = _Prop("FocalLength", "double")
    GuideRateDeclination = _Prop("GuideRateDeclination", "double", writable=True)
    GuideRateRightAscension = _Prop("GuideRateRightAscension", "double", writable=True)
    IsPulseGuiding = _Prop("IsPulseGuiding", "bool")
    RightAscension = _Prop("RightAscension", "double")
    RightAscensionRate = _Prop("RightAscensionRate", "double", writable=True)
    SideOfPier = _Prop("SideOfPier", "int", writable=True, timeout="long")
    SiderealTime = _Prop("SiderealTime", "double")
    SiteElevation = _Prop("SiteElevation", "double", writable=True)
    SiteLatitude = _Prop("SiteLatitude", "double", writable=True)
    SiteLongitude = _Prop("SiteLongitude", "double", writable=True)
    Slewing = _Prop("Slewing", "bool")
    SlewSettleTime = _Prop("SlewSettleTime", "int", writable=True)
    TargetDeclination = _Prop("TargetDeclination", "double", writable=True)
    TargetRightAscension = _Prop("TargetRightAscension", "double", writable=True)
    Tracking = _Prop("Tracking", "bool", writable=True)
    TrackingRate = _Prop("TrackingRate", "int", writable=True)
    TrackingRates = _Prop("TrackingRates", "list")
    UTCDate = _Prop("UTCDate", "date", writable=True)

    # -- telescope functions and methods ----------------------------------------------------------------
    def AxisRates(self, axis: int) -> list[tuple[float, float]]:
        rates = self.get_value("AxisRates", "list", [("Axis", str(axis))])
        result = []
        for rate in rates or []:
            if not isinstance(rate, dict):
                raise JsonException(f"AxisRates element {rate!r} is not an object")
            # Case-sensitive keys: a miscased Minimum/Maximum reads as 0.0.
            result.append((_typed(rate.get("Minimum", 0.0), "double"), _typed(rate.get("Maximum", 0.0), "double")))
        return result  # type: ignore[return-value]

    def CanMoveAxis(self, axis: int) -> bool:
        return self.get_value("CanMoveAxis", "bool", [("Axis", str(axis))])

    def DestinationSideOfPier(self, ra: float, dec: float) -> int:
        return self.get_value("DestinationSideOfPier", "int",
                              [("RightAscension", dotnet_double(ra)), ("Declination", dotnet_double(dec))])

    def AbortSlew(self) -> None:
        self.put("AbortSlew", [], timeout="long")

    def FindHome(self) -> None:
        self.put("FindHome", [], timeout="long")

    def MoveAxis(self, axis: int, rate: float) -> None:
        self.put("MoveAxis", [("Axis", str(axis)), ("Rate", dotnet_double(rate))], timeout="long")

    def Park(self) -> None:
        self.put("Park", [], timeout="long")

    def PulseGuide(self, direction: int, duration: int) -> None:
        self.put("PulseGuide", [("Direction", str(direction)), ("Duration", str(duration))], timeout="long")

    def SetPark(self) -> None:
        self.put("SetPark", [])

    def SlewToAltAz(self, azimuth: float, altitude: float) -> None:
        self.put("SlewToAltAz", [("Azimuth", dotnet_double(azimuth)), ("Altitude", dotnet_double(altitude))],
                 timeout="long")

    def SlewToAltAzAsync(self, azimuth: float, altitude: float) -> None:
        self.put("SlewToAltAzAsync", [("Azimuth", dotnet_double(azimuth)), ("Altitude", dotnet_double(altitude))],
                 timeout="long")

    def SlewToCoordinates(self, ra: float, dec: float) -> None:
        self.put("SlewToCoordinates", [("RightAscension", dotnet_double(ra)), ("Declination", dotnet_double(dec))],
                 timeout="long")

    def SlewToCoordinatesAsync(self, ra: float, dec: float) -> None:
        self.put("SlewToCoordinatesAsync",
                 [("RightAscension", dotnet_double(ra)), ("Declination", dotnet_double(dec))], timeout="long")

    def SlewToTarget(self) -> None:
        self.put("SlewToTarget", [], timeout="long")

    def SlewToTargetAsync(self) -> None:
        self.put("SlewToTargetAsync", [], timeout="long")

    def SyncToAltAz(self, azimuth: float, altitude: float) -> None:
        self.put("SyncToAltAz", [("Azimuth", dotnet_double(azimuth)), ("Altitude", dotnet_double(altitude))])

    def SyncToCoordinates(self, ra: float, dec: float) -> None:
        self.put("SyncToCoordinates", [("RightAscension", dotnet_double(ra)), ("Declination", dotnet_double(dec))])

    def SyncToTarget(self) -> None:
        self.put("SyncToTarget", [])

    def Unpark(self) -> None:
        self.put("Unpark", [], timeout="long")


def parse_reply(member: str, response: requests.Response) -> dict[str, Any]:
    """The reply checks RemoteDevice makes before it looks at the error fields (RD L710-L772)."""
    status = response.status_code
    if not 200 <= status < 300:
        raise DriverException(f"Error calling p.Method: {member}, HTTP Completion Status: {status}, "
                              f"Error Message: {response.text.strip()}")
    content_type = (response.headers.get("Content-Type") or "").lower()
    if "application/json" not in content_type and "application/imagebytes" not in content_type:
        raise InvalidValueException("The device did not return a content type or returned an unsupported "
                                    f"content type ({member}: {content_type or 'none'})")
    try:
        body = json.loads(response.text)
    except ValueError as exc:
        raise JsonException(f"{member}: the reply is not JSON: {exc}: {response.text[:200]!r}") from exc
    if not isinstance(body, dict):
        raise JsonException(f"{member}: the reply is not a JSON object: {response.text[:200]!r}")
    number = body.get("ErrorNumber", 0)
    message = body.get("ErrorMessage", "")
    if isinstance(number, bool) or not isinstance(number, int):
        raise JsonException(f"{member}: ErrorNumber {number!r} is not an integer")
    if message is not None and not isinstance(message, str):
        raise JsonException(f"{member}: ErrorMessage {message!r} is not a string")
    return body


def check_reply(member: str, response: requests.Response) -> dict[str, Any]:
    """RemoteDevice's reply rules (RD L710-L864); returns the parsed JSON object of a success."""
    body = parse_reply(member, response)
    # Keys are case-sensitive: a miscased ErrorNumber/ErrorMessage is simply absent ("no error").
    number, message = body.get("ErrorNumber", 0), body.get("ErrorMessage", "")
    if message != "" or number != 0:  # a JSON null message counts as an error too
        raise exception_for(number, message or "")
    if body.get("DriverException") is not None:
        raise DriverException(f"{member}: the reply carries a DriverException: {body['DriverException']!r}")
    return body


# --- alpyca -------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _alpyca_errors() -> Iterator[None]:
    """alpyca's exception classes -> the ASCOM ones above (same numbers, same meaning)."""
    from alpaca import exceptions as ax

    try:
        yield
    except (ax.NotImplementedException, ax.InvalidValueException, ax.ValueNotSetException,
            ax.NotConnectedException, ax.ParkedException, ax.SlavedException, ax.InvalidOperationException,
            ax.ActionNotImplementedException, ax.OperationCancelledException) as exc:
        raise exception_for(exc.number, exc.message) from exc
    except ax.DriverException as exc:
        raise exception_for(exc.number, exc.message) from exc
    except ax.AlpacaRequestException as exc:
        raise DriverException(f"HTTP Completion Status: {exc.number}, Error Message: {exc.message}") from exc
    except requests.Timeout as exc:
        raise ConformTimeout(str(exc)) from exc
    except requests.RequestException as exc:
        raise DriverException(str(exc)) from exc
    except (KeyError, TypeError, ValueError) as exc:  # alpyca indexing a reply that lacks a key
        raise JsonException(f"alpyca could not read the reply: {exc!r}") from exc


class AlpycaTelescope:
    """alpyca's ``Telescope`` with ConformU's reply rules and exceptions; same member names as above.

    Property reads and writes and method calls are forwarded by name; enum-typed arguments are
    converted to alpyca's enums so its own request building is what goes on the wire.
    """

    def __init__(self, host: str, port: int, device_number: int = 0) -> None:
        from alpaca.telescope import Telescope

        object.__setattr__(self, "_scope", Telescope(f"{host}:{port}", device_number))
        self._scope.rqs.hooks["response"].append(_alpyca_reply_hook)

    def __getattr__(self, name: str) -> Any:
        attr = getattr(type(self._scope), name)
        if isinstance(attr, property):
            with _alpyca_errors():
                value = attr.fget(self._scope)  # type: ignore[misc]
            return _plain(value)

        def call(*args: Any) -> Any:
            converted = [_alpyca_arg(name, i, a) for i, a in enumerate(args)]
            with _alpyca_errors():
                return _plain(getattr(self._scope, name)(*converted))

        return call

    def __setattr__(self, name: str, value: Any) -> None:
        with _alpyca_errors():
            setattr(self._scope, name, value)


def _alpyca_arg(member: str, index: int, value: Any) -> Any:
    from alpaca.telescope import GuideDirections, TelescopeAxes

    if index == 0 and member in ("AxisRates", "CanMoveAxis", "MoveAxis"):
        return TelescopeAxes(value)
    if index == 0 and member == "PulseGuide":
        return GuideDirections(value)
    return value


def _plain(value: Any) -> Any:
    """alpyca's enums and Rate objects -> the plain values the tester compares."""
    from alpaca.telescope import Rate

    if isinstance(value, list):
        return [(r.Minimum, r.Maximum) if isinstance(r, Rate) else _plain(r) for r in value]
    if hasattr(value, "value") and not isinstance(value, (bool, int, float, str)):
        return value.value
    return value


def _alpyca_reply_hook(response: requests.Response, *args: Any, **kwargs: Any) -> requests.Response:
    """Add the reply rules ConformU's client applies and alpyca does not.

    alpyca raises for a non-zero ErrorNumber itself (its table is the same); it does not check the
    Content-Type, ignores an ErrorMessage that comes with ErrorNumber 0 and ignores a DriverException
    key, so those are checked here exactly as :func:`check_reply` does.
    """
    if 200 <= response.status_code < 300:
        member = response.url.rsplit("/", 1)[-1].split("?", 1)[0]
        body = parse_reply(member, response)
        number, message = body.get("ErrorNumber", 0), body.get("ErrorMessage", "")
        if number == 0 and message != "":
            raise exception_for(0, message or "")
        if number == 0 and body.get("DriverException") is not None:
            raise DriverException(f"{member}: the reply carries a DriverException: {body['DriverException']!r}")
    return response


def julian_date(moment: datetime) -> float:
    """``DateTime.ToOADate() + 2415018.5`` for a UTC moment."""
    oa_epoch = datetime(1899, 12, 30, tzinfo=timezone.utc)
    return (moment - oa_epoch) / timedelta(days=1) + 2415018.5
