"""Capabilities over HTTP: what the mount can do reads true, what it lacks reads false and answers 0x400."""

from __future__ import annotations

from alpaca_zwo.server import AlpacaZwoServer
from alpaca_zwo.telescope.actions import supported_actions
from tests.telescope.expectations import not_implemented_cases
from tests.telescope.harness import Api, make_transport, run_cases


def test_lacking_capabilities_report_false_and_answer_0x400(server: AlpacaZwoServer, api: Api,
                                                            transport_kind: str) -> None:
    assert api.value("CanMoveAxis", Axis=2) is False
    assert api.value("AxisRates", Axis=2) == []
    assert api.value("DeclinationRate") == 0.0
    assert api.value("RightAscensionRate") == 0.0
    assert api.value("DoesRefraction") is False
    assert api.value("SupportedActions") == supported_actions()  # the ZWO actions (tests/alpaca/test_actions.py)
    run_cases(make_transport(transport_kind, server, api), not_implemented_cases())


def test_implemented_capabilities_report_true(api: Api) -> None:
    for name in ("CanFindHome", "CanPark", "CanPulseGuide", "CanSetGuideRates", "CanSetPark", "CanSetTracking",
                 "CanSlew", "CanSlewAltAz", "CanSlewAltAzAsync", "CanSlewAsync", "CanSync", "CanSyncAltAz",
                 "CanUnpark", "CanSetRightAscensionRate", "CanSetDeclinationRate", "CanSetPierSide"):
        assert api.value(name) is True, name
    assert api.value("CanMoveAxis", Axis=0) is True
    assert api.value("CanMoveAxis", Axis=1) is True
