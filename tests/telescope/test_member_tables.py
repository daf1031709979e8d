"""Every member over real HTTP: the member tables cover every member, each answers with a valid envelope,
and the error tables (not connected, invalid values, parked) hold through both ``requests`` and ``alpyca``.
"""

from __future__ import annotations

from datetime import datetime, timezone

from alpaca_zwo.alpaca.members import DEVICE_MEMBERS
from alpaca_zwo.server import AlpacaZwoServer
from tests.support import wait_until
from tests.telescope.expectations import (
    _COMMANDS,
    _NOT_IMPLEMENTED_GETS,
    _NOT_IMPLEMENTED_PUTS,
    VALID_ARGS,
    args_for,
    disconnected_cases,
    disconnected_expectation,
    invalid_value_cases,
    parked_cases,
)
from tests.telescope.harness import (
    ACTION_NOT_IMPLEMENTED,
    INVALID_VALUE,
    NOT_IMPLEMENTED,
    OK,
    VALUE_NOT_SET,
    Api,
    Case,
    make_transport,
    run_cases,
)


def test_member_tables_cover_every_member() -> None:
    """Every (verb, member) of the server's table has valid arguments and a disconnected expectation."""
    for member in DEVICE_MEMBERS["telescope"]:
        args_for(member.verb, member.name)  # raises if VALID_ARGS is missing or stale
        assert disconnected_expectation(member.verb, member.name)
    assert {(c.verb, c.name) for c in disconnected_cases()} == {
        (m.verb, m.name) for m in DEVICE_MEMBERS["telescope"] if m.name != "Connect"}


def test_every_member_answers_with_a_valid_envelope(server: AlpacaZwoServer, url: str) -> None:
    """One pass over all members in a sane order; Api checks the envelope (R1) of each reply."""
    api = Api(url)
    assert api.value("Connected") is False
    api.connect()
    assert api.value("Connected") is True

    # Reads.
    for member in DEVICE_MEMBERS["telescope"]:
        if member.verb != "GET" or member.params:
            continue
        expected = VALUE_NOT_SET if member.name.startswith("Target") else (
            NOT_IMPLEMENTED if member.name in _NOT_IMPLEMENTED_GETS else OK)
        reply = api.get(member.name)
        assert reply.error == expected, f"GET {member.name}: {reply.body}"
    for axis in (0, 1, 2):
        api.get("AxisRates", Axis=axis)
        api.get("CanMoveAxis", Axis=axis)
    assert api.value("DestinationSideOfPier", RightAscension=api.ra_at_ha(-3.0), Declination=30.0) in (0, 1)

    # Property writes (values that keep the mount where it is).
    for name in ("GuideRateDeclination", "GuideRateRightAscension", "SiteElevation", "SiteLatitude",
                 "SiteLongitude", "SlewSettleTime", "TargetDeclination", "TargetRightAscension", "Tracking",
                 "TrackingRate", "DoesRefraction", "DeclinationRate", "RightAscensionRate"):
        api.ok(name, **VALID_ARGS[name])
    api.ok("UTCDate", UTCDate=datetime.now(timezone.utc))
    for name in _NOT_IMPLEMENTED_PUTS:
        assert api.put(name, **VALID_ARGS[name]).error == NOT_IMPLEMENTED
    assert api.put("Action", **VALID_ARGS["Action"]).error == ACTION_NOT_IMPLEMENTED
    for name in _COMMANDS:
        assert api.put(name, **VALID_ARGS[name]).error == NOT_IMPLEMENTED

    # Motions, syncs and the rest, each run to completion.
    api.ok("Tracking", Tracking=True)
    api.ok("SlewToCoordinates", RightAscension=api.ra_at_ha(-2.0), Declination=40.0)
    api.ok("SlewToCoordinatesAsync", RightAscension=api.ra_at_ha(-2.5), Declination=35.0)
    api.wait_idle()
    api.ok("TargetRightAscension", TargetRightAscension=api.ra_at_ha(-3.0))
    api.ok("TargetDeclination", TargetDeclination=30.0)
    api.ok("SlewToTarget")
    api.ok("TargetRightAscension", TargetRightAscension=api.ra_at_ha(-2.8))
    api.ok("SlewToTargetAsync")
    api.wait_idle()
    here = api.state()
    api.ok("SyncToCoordinates", RightAscension=here["RightAscension"], Declination=here["Declination"] + 0.01)
    api.ok("SyncToTarget")
    api.ok("Tracking", Tracking=False)
    api.ok("SlewToAltAz", Azimuth=120.0, Altitude=45.0)
    api.ok("SlewToAltAzAsync", Azimuth=125.0, Altitude=45.0)
    api.wait_idle()
    api.ok("SyncToAltAz", Azimuth=api.value("Azimuth"), Altitude=api.value("Altitude"))
    api.ok("MoveAxis", Axis=0, Rate=0.0)
    api.ok("Tracking", Tracking=True)
    api.ok("SideOfPier", SideOfPier=api.value("SideOfPier"))  # the side held: nothing moves
    api.ok("PulseGuide", Direction=0, Duration=100)
    wait_until(lambda: api.value("IsPulseGuiding") is False, 10, "the pulse to end")
    api.ok("AbortSlew")
    api.ok("FindHome")
    api.wait_idle()
    api.ok("SetPark")
    api.ok("Park")
    api.wait_idle()
    api.ok("Unpark")
    api.ok("Disconnect")
    wait_until(lambda: api.value("Connecting") is False, 5, "Disconnect to finish")
    api.ok("Connect")
    wait_until(lambda: api.value("Connecting") is False, 5, "Connect to finish")
    api.ok("Connected", Connected=False)

    everything = {(m.verb, m.name) for m in DEVICE_MEMBERS["telescope"]}
    assert api.exercised == everything, f"not exercised: {sorted(everything - api.exercised)}"


def test_ascom_errors_carry_default_value_and_a_message(api: Api) -> None:
    """Errors of value-returning members carry the type's default Value, never null (protocol-rules §6)."""
    reply = api.get("TargetRightAscension")
    assert reply.error == VALUE_NOT_SET and reply.body["Value"] == 0.0 and reply.body["ErrorMessage"]
    reply = api.put("SiteLatitude", SiteLatitude=95.0)
    assert reply.error == INVALID_VALUE and "Value" not in reply.body


def test_server_transaction_ids_increase(api: Api) -> None:
    ids = [api.get("Name").body["ServerTransactionID"] for _ in range(5)]
    assert ids == sorted(ids) and len(set(ids)) == 5


def test_not_connected_answers_0x407(server: AlpacaZwoServer, fresh: Api, transport_kind: str) -> None:
    """No client has connected since the server started: everything touching the mount is 0x407."""
    run_cases(make_transport(transport_kind, server, fresh), disconnected_cases())
    assert fresh.value("Connected") is False


def test_not_connected_after_the_last_client_disconnects(server: AlpacaZwoServer, url: str,
                                                         transport_kind: str) -> None:
    """Connected reads false for everyone once the last client disconnected, so the mount is off limits.

    The server keeps the serial link open for a while to make reconnects instant; that must not make
    a disconnected device answer (or move) as if it were connected.
    """
    api = Api(url).connect()
    api.ok("Connected", Connected=False)
    assert api.value("Connected") is False
    run_cases(make_transport(transport_kind, server, api), disconnected_cases())


def test_invalid_values_answer_0x401(server: AlpacaZwoServer, api: Api, transport_kind: str) -> None:
    run_cases(make_transport(transport_kind, server, api), invalid_value_cases())
    assert api.value("SiteLatitude") == 51.4769  # unchanged by the refused writes


def test_parked_answers_0x408(server: AlpacaZwoServer, api: Api, transport_kind: str) -> None:
    api.ok("TargetRightAscension", TargetRightAscension=3.0)
    api.ok("TargetDeclination", TargetDeclination=20.0)
    api.ok("Park")
    api.wait_idle()
    assert api.value("AtPark") is True

    def still_parked(c: Case) -> str | None:
        if api.value("AtPark") is not True:
            api.ok("Park")  # keep the remaining cases meaningful
            api.wait_idle()
            return "the call unparked the telescope"
        if api.value("Slewing") is not False:
            api.wait_idle()
            return "the call moved the parked telescope"
        return None

    run_cases(make_transport(transport_kind, server, api), parked_cases(), after=still_parked)
    assert api.value("Tracking") is False
