"""Fixtures for the Alpaca protocol layer: a real waitress server on loopback and a stand-in device.

STAND-IN NOTICE: :class:`StandInTelescope` is a small in-memory device that exists only because
the real, emulator-backed ``Telescope`` has not landed yet. It implements the ``AlpacaDevice``
handler contract with just enough behaviour (a few ASCOM errors, parked state, unset targets) to
exercise every protocol path. When the real Telescope exists, the lead switches these fixtures
to it; tests that need fault injection keep using the ``faults`` hook below.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

import pytest

from alpaca_zwo._exceptions import (
    ActionNotImplemented,
    InvalidValue,
    MemberNotImplemented,
    Parked,
    ValueNotSet,
)
from alpaca_zwo.alpaca import HttpServer, ServerInfo, create_app
from alpaca_zwo.alpaca.members import DEVICE_MEMBERS
from alpaca_zwo.clients import ClientKey, ClientRegistry, current_client
from tests.support import AlpacaClient

HANDLERS = frozenset(m.handler for m in DEVICE_MEMBERS["telescope"] if m.constant is None)
#: The parts the member table names (``connection``, ``capabilities``...): the stand-in is all of them.
OWNERS = frozenset(m.owner for m in DEVICE_MEMBERS["telescope"] if m.owner is not None)

# ConformU's protocol-suite constants (checklist §C.1).
CLIENT_ID = 123456
CTID = 67890
BAD_VALUE = "asduio6fghZZ"
OK_IDS = {"ClientID": str(CLIENT_ID), "ClientTransactionID": str(CTID)}


@dataclass
class Call:
    """One handler invocation as the device saw it."""

    handler: str
    args: tuple[Any, ...]
    kwargs: dict[str, Any]
    client: ClientKey | None


def _wrap(name: str, original: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(original)
    def wrapper(self: StandInTelescope, *args: Any, **kwargs: Any) -> Any:
        self.calls.append(Call(name, args, kwargs, current_client.get()))
        fault = self.faults.get(name)
        if isinstance(fault, BaseException) or (isinstance(fault, type) and issubclass(fault, BaseException)):
            raise fault
        if fault is not None:
            return fault(*args, **kwargs)
        return original(self, *args, **kwargs)

    return wrapper


def _itself(self: StandInTelescope) -> StandInTelescope:
    return self


def _instrumented(cls: type) -> type:
    """Wrap every handler so tests can see calls (and who made them) and inject faults by name; every
    part the member table names is the stand-in itself, so it keeps each handler in one flat class."""
    for name in HANDLERS:
        setattr(cls, name, _wrap(name, getattr(cls, name)))
    for owner in OWNERS:
        setattr(cls, owner, property(_itself))
    return cls


@_instrumented
class StandInTelescope:
    """In-memory ITelescopeV4 stand-in (see module docstring); not a model of any real mount."""

    def __init__(self, name: str = "Stand-in telescope",
                 unique_id: str = "5f0c1f6e-0000-4000-8000-000000000001") -> None:
        self.device_name = name
        self.unique_id = unique_id
        self.calls: list[Call] = []
        #: handler name -> exception (class or instance) to raise, or a callable to run instead.
        self.faults: dict[str, Any] = {}
        self._lock = threading.Lock()
        self._connected = False
        self._tracking = False
        self._parked = False
        self._slewing = False
        self._ra, self._dec = 5.5, 45.0
        self._target_ra: float | None = None
        self._target_dec: float | None = None
        self._rates = {"declination_rate": 0.0, "right_ascension_rate": 0.0,
                       "guide_rate_declination": 0.004, "guide_rate_right_ascension": 0.004}
        self._does_refraction = False
        self._side_of_pier = 0
        self._site = {"elevation": 100.0, "latitude": 51.5, "longitude": -0.1}
        self._slew_settle_time = 0
        self._tracking_rate = 0
        self._utc = datetime(2024, 1, 31, 21, 5, 0, 123456, tzinfo=timezone.utc)

    def called(self, handler: str) -> list[Call]:
        return [c for c in self.calls if c.handler == handler]

    # --- common -------------------------------------------------------------------------------
    def action(self, action: str, parameters: str) -> str:
        if action != "echo":
            raise ActionNotImplemented(f"Action {action!r} is not supported")
        return parameters

    def command_blind(self, command: str, raw: bool) -> None:
        raise MemberNotImplemented("CommandBlind is not implemented")

    def command_bool(self, command: str, raw: bool) -> bool:
        raise MemberNotImplemented("CommandBool is not implemented")

    def command_string(self, command: str, raw: bool) -> str:
        raise MemberNotImplemented("CommandString is not implemented")

    def connect(self) -> None:
        self._connected = True

    def connected(self) -> bool:
        return self._connected

    def set_connected(self, value: bool) -> None:
        self._connected = value

    def connecting(self) -> bool:
        return False

    def description(self) -> str:
        return "In-memory stand-in for protocol tests"

    def device_state(self) -> list[tuple[str, object]]:
        return [("Altitude", 30.0), ("AtHome", False), ("AtPark", self._parked), ("Azimuth", 180.0),
                ("Declination", self._dec), ("IsPulseGuiding", False), ("RightAscension", self._ra),
                ("SideOfPier", self._side_of_pier), ("SiderealTime", 6.0), ("Slewing", self._slewing),
                ("Tracking", self._tracking), ("UTCDate", self._utc), ("TimeStamp", self._utc)]

    def disconnect(self) -> None:
        self._connected = False

    def name(self) -> str:
        return self.device_name

    def supported_actions(self) -> list[str]:
        return ["echo"]

    # --- telescope properties -------------------------------------------------------------------
    def alignment_mode(self) -> int:
        return 2

    def altitude(self) -> float:
        return 30.0

    def aperture_area(self) -> float:
        return 0.0

    def aperture_diameter(self) -> float:
        return 0.0

    def at_home(self) -> bool:
        return False

    def at_park(self) -> bool:
        return self._parked

    def azimuth(self) -> float:
        return 180.0

    def can_set_pier_side(self) -> bool:
        return False

    def declination(self) -> float:
        return self._dec

    def declination_rate(self) -> float:
        return self._rates["declination_rate"]

    def set_declination_rate(self, value: float) -> None:
        self._rates["declination_rate"] = value

    def set_does_refraction(self, value: bool) -> None:
        self._does_refraction = value

    def focal_length(self) -> float:
        return 0.0

    def guide_rate_declination(self) -> float:
        return self._rates["guide_rate_declination"]

    def set_guide_rate_declination(self, value: float) -> None:
        self._rates["guide_rate_declination"] = value

    def guide_rate_right_ascension(self) -> float:
        return self._rates["guide_rate_right_ascension"]

    def set_guide_rate_right_ascension(self, value: float) -> None:
        self._rates["guide_rate_right_ascension"] = value

    def is_pulse_guiding(self) -> bool:
        return False

    def right_ascension(self) -> float:
        return self._ra

    def right_ascension_rate(self) -> float:
        return self._rates["right_ascension_rate"]

    def set_right_ascension_rate(self, value: float) -> None:
        self._rates["right_ascension_rate"] = value

    def side_of_pier(self) -> int:
        return self._side_of_pier

    def set_side_of_pier(self, value: int) -> None:
        raise MemberNotImplemented("SideOfPier cannot be set")

    def sidereal_time(self) -> float:
        return 6.0

    def site_elevation(self) -> float:
        return self._site["elevation"]

    def set_site_elevation(self, value: float) -> None:
        if not -300 <= value <= 10000:
            raise InvalidValue(f"SiteElevation {value} is outside -300..10000")
        self._site["elevation"] = value

    def site_latitude(self) -> float:
        return self._site["latitude"]

    def set_site_latitude(self, value: float) -> None:
        if not -90 <= value <= 90:
            raise InvalidValue(f"SiteLatitude {value} is outside -90..90")
        self._site["latitude"] = value

    def site_longitude(self) -> float:
        return self._site["longitude"]

    def set_site_longitude(self, value: float) -> None:
        if not -180 <= value <= 180:
            raise InvalidValue(f"SiteLongitude {value} is outside -180..180")
        self._site["longitude"] = value

    def slewing(self) -> bool:
        return self._slewing

    def slew_settle_time(self) -> int:
        return self._slew_settle_time

    def set_slew_settle_time(self, value: int) -> None:
        if value < 0:
            raise InvalidValue("SlewSettleTime must not be negative")
        self._slew_settle_time = value

    def target_declination(self) -> float:
        if self._target_dec is None:
            raise ValueNotSet("TargetDeclination has not been set")
        return self._target_dec

    def set_target_declination(self, value: float) -> None:
        if not -90 <= value <= 90:
            raise InvalidValue(f"TargetDeclination {value} is outside -90..90")
        self._target_dec = value

    def target_right_ascension(self) -> float:
        if self._target_ra is None:
            raise ValueNotSet("TargetRightAscension has not been set")
        return self._target_ra

    def set_target_right_ascension(self, value: float) -> None:
        if not 0 <= value < 24:
            raise InvalidValue(f"TargetRightAscension {value} is outside 0..24")
        self._target_ra = value

    def tracking(self) -> bool:
        return self._tracking

    def set_tracking(self, value: bool) -> None:
        if value and self._parked:
            raise Parked("Cannot track while parked")
        self._tracking = value

    def tracking_rate(self) -> int:
        return self._tracking_rate

    def set_tracking_rate(self, value: int) -> None:
        if value not in (0, 1, 2):
            raise InvalidValue(f"TrackingRate {value} is not supported")
        self._tracking_rate = value

    def tracking_rates(self) -> list[int]:
        return [0, 1, 2]

    def utc_date(self) -> datetime:
        return self._utc

    def set_utc_date(self, value: datetime) -> None:
        self._utc = value

    # --- telescope functions --------------------------------------------------------------------
    def axis_rates(self, axis: int) -> list[tuple[float, float]]:
        if axis not in (0, 1, 2):
            raise InvalidValue(f"Axis {axis} does not exist")
        return [] if axis == 2 else [(0.0, 4.0)]

    def can_move_axis(self, axis: int) -> bool:
        if axis not in (0, 1, 2):
            raise InvalidValue(f"Axis {axis} does not exist")
        return axis < 2

    def destination_side_of_pier(self, right_ascension: float, declination: float) -> int:
        return 0 if right_ascension < 12 else 1

    # --- telescope methods ----------------------------------------------------------------------
    def _not_parked(self) -> None:
        if self._parked:
            raise Parked("The mount is parked")

    def abort_slew(self) -> None:
        self._not_parked()
        self._slewing = False

    def find_home(self) -> None:
        self._not_parked()

    def move_axis(self, axis: int, rate: float) -> None:
        self._not_parked()
        if axis not in (0, 1):
            raise InvalidValue(f"Axis {axis} cannot be moved")

    def park(self) -> None:
        self._parked = True
        self._tracking = False

    def pulse_guide(self, direction: int, duration: int) -> None:
        self._not_parked()
        if direction not in (0, 1, 2, 3) or duration < 0:
            raise InvalidValue("Bad direction or duration")

    def set_park(self) -> None:
        pass

    def slew_to_alt_az(self, azimuth: float, altitude: float) -> None:
        raise MemberNotImplemented("SlewToAltAz is not supported")

    def slew_to_alt_az_async(self, azimuth: float, altitude: float) -> None:
        raise MemberNotImplemented("SlewToAltAzAsync is not supported")

    def slew_to_coordinates(self, right_ascension: float, declination: float) -> None:
        self.slew_to_coordinates_async(right_ascension=right_ascension, declination=declination)

    def slew_to_coordinates_async(self, right_ascension: float, declination: float) -> None:
        self._not_parked()
        self._target_ra, self._target_dec = right_ascension, declination
        self._ra, self._dec = right_ascension, declination

    def slew_to_target(self) -> None:
        self.slew_to_target_async()

    def slew_to_target_async(self) -> None:
        self._not_parked()
        if self._target_ra is None or self._target_dec is None:
            raise ValueNotSet("Target not set")
        self._ra, self._dec = self._target_ra, self._target_dec

    def sync_to_alt_az(self, azimuth: float, altitude: float) -> None:
        raise MemberNotImplemented("SyncToAltAz is not supported")

    def sync_to_coordinates(self, right_ascension: float, declination: float) -> None:
        self._not_parked()
        self._target_ra, self._target_dec = right_ascension, declination
        self._ra, self._dec = right_ascension, declination

    def sync_to_target(self) -> None:
        self.slew_to_target_async()

    def unpark(self) -> None:
        self._parked = False


class Alpaca(AlpacaClient):
    """A running server plus the shared test client, used at its raw level the way ConformU's protocol suite is."""

    def __init__(self, server: HttpServer, device: StandInTelescope, registry: ClientRegistry) -> None:
        super().__init__(server.port, CLIENT_ID)
        self.server = server
        self.device = device
        self.registry = registry


SERVER_INFO = ServerInfo("alpaca-zwo test", "alpaca-zwo project", "0.1.0", "Test bench")


@pytest.fixture
def make_alpaca() -> Iterator[Callable[..., Alpaca]]:
    """Factory: start a server with create_app options (and optionally other devices)."""
    started: list[Alpaca] = []

    def make(devices: list[Any] | None = None, *, threads: int = 8, **options: Any) -> Alpaca:
        devices = devices if devices is not None else [StandInTelescope()]
        registry = ClientRegistry()
        app = create_app(devices, registry, SERVER_INFO, **options)
        server = HttpServer(app, "127.0.0.1", 0, threads=threads)
        server.start()
        alpaca = Alpaca(server, devices[0] if devices else StandInTelescope(), registry)
        started.append(alpaca)
        return alpaca

    yield make
    for alpaca in started:
        alpaca.session.close()
        alpaca.server.close()


@pytest.fixture
def alpaca(make_alpaca: Callable[..., Alpaca]) -> Alpaca:
    """A fresh server (ServerTransactionID starts at 1) with one stand-in telescope."""
    return make_alpaca()
