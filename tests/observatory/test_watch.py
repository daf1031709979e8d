"""The observatory interlock's parts without a mount: the settings, the verdict rules, the gate, and the
SafetyWatch against a real third-party SafetyMonitor and Dome (alpaca-simulators on a loopback port)."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import pytest

from alpaca_zwo._exceptions import ConfigError, SafetyRefusal
from alpaca_zwo.config.settings import SafetySettings, Settings, settings_from_dict
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.motion.interlock import Interlock, SafetyState, Verdict
from alpaca_zwo.observatory.watch import DeviceReading, SafetyWatch, judge
from tests.support.observatory import AlpacaSimulators


@pytest.mark.parametrize(("given", "stored"), [
    ("", ""),
    ("  ", ""),
    ("http://192.168.1.30:11111/api/v1/safetymonitor/0", "http://192.168.1.30:11111/api/v1/safetymonitor/0"),
    ("HTTP://Obs.local:11111/API/V1/SafetyMonitor/02/", "http://obs.local:11111/api/v1/safetymonitor/2"),
    ("https://[fd00::7]/api/v1/safetymonitor/1", "https://[fd00::7]/api/v1/safetymonitor/1"),
    # As the page's label writes it (issue 43 point 9): no scheme is plain http.
    ("192.168.1.30:11111/api/v1/safetymonitor/0", "http://192.168.1.30:11111/api/v1/safetymonitor/0"),
    ("h:11111/api/v1/safetymonitor/0", "http://h:11111/api/v1/safetymonitor/0"),
])
def test_monitor_urls_are_stored_canonically(given: str, stored: str) -> None:
    assert settings_from_dict({"safety": {"monitor": given}}).safety.monitor == stored


@pytest.mark.parametrize("bad", [
    "ftp://h/api/v1/safetymonitor/0", "h:11111/api/v1/dome/0", "http://h/api/v1/dome/0",
    "http://h/api/v1/safetymonitor", "http://h/api/v1/safetymonitor/x", "http://u:p@h/api/v1/safetymonitor/0",
    "http://h:0/api/v1/safetymonitor/0", "http://h:70000/api/v1/safetymonitor/0",
    "http://h/api/v1/safetymonitor/0?x=1", "http://h/api/v1/safetymonitor/0#f", 7, None,
    "[", "http://[fd00::7/api/v1/safetymonitor/0",  # an unclosed IPv6 bracket (the fuzzer found a 500)
])
def test_bad_monitor_urls_are_refused_with_the_key(bad: object) -> None:
    with pytest.raises(ConfigError, match=r"safety\.monitor"):
        settings_from_dict({"safety": {"monitor": bad}})


def test_roof_takes_a_dome_and_the_other_keys_are_checked() -> None:
    assert settings_from_dict({"safety": {"roof": "http://h:1/api/v1/dome/0"}}).safety.roof == "http://h:1/api/v1/dome/0"
    with pytest.raises(ConfigError, match=r"safety\.roof"):
        settings_from_dict({"safety": {"roof": "http://h:1/api/v1/safetymonitor/0"}})
    with pytest.raises(ConfigError, match=r"safety\.on_unsafe"):
        settings_from_dict({"safety": {"on_unsafe": "flee"}})
    with pytest.raises(ConfigError, match=r"safety\.unreachable_s: must be at least poll_s"):
        settings_from_dict({"safety": {"poll_s": 10, "unreachable_s": 5}})
    defaults = SafetySettings()
    assert (defaults.monitor, defaults.roof, defaults.poll_s, defaults.unreachable_s, defaults.on_unsafe) == (
        "", "", 5.0, 30.0, "park")


def test_judge_by_answer_age_and_errors() -> None:
    """The last answer decides for unreachable_s, errors or not; before any answer: unknown, then unsafe."""
    reading = DeviceReading("monitor", "u")
    assert judge(reading, now=10.0, started=0.0, unreachable_s=30.0)[0] is SafetyState.UNKNOWN
    assert judge(reading, now=31.0, started=0.0, unreachable_s=30.0) == (SafetyState.UNSAFE,
                                                                         "no answer for 31 s (no reply)")
    reading.ok, reading.answer, reading.answered_at = True, "IsSafe=true", 100.0
    reading.error = "no answer: timed out"
    assert judge(reading, now=129.0, started=0.0, unreachable_s=30.0) == (SafetyState.SAFE, "IsSafe=true")
    assert judge(reading, now=131.0, started=0.0, unreachable_s=30.0) == (
        SafetyState.UNSAFE, "no answer for 31 s (no answer: timed out)")
    reading.ok, reading.answer = False, "IsSafe=false"
    assert judge(reading, now=101.0, started=0.0, unreachable_s=30.0) == (SafetyState.UNSAFE, "IsSafe=false")


def test_the_gate_refuses_with_0x40b_naming_the_monitor() -> None:
    gate = Interlock()
    gate.require("Unpark")  # off: everything allowed
    assert gate.guard()()
    gate.set(Verdict(SafetyState.UNSAFE, "http://m/api/v1/safetymonitor/0", "IsSafe=false"))
    with pytest.raises(SafetyRefusal) as refused:
        gate.require("Unpark")
    assert refused.value.number == 0x40B
    assert "safety monitor" in refused.value.message and "IsSafe=false" in refused.value.message
    assert not gate.guard()()
    gate.set(Verdict(SafetyState.UNKNOWN, "http://m/api/v1/safetymonitor/0", "waiting"))
    with pytest.raises(SafetyRefusal, match="has not answered yet"):
        gate.require("MoveAxis")


def _watch(sims: AlpacaSimulators, **safety: object) -> tuple[SafetyWatch, Interlock]:
    store = SettingsStore(Settings(safety=SafetySettings(**safety)))  # type: ignore[arg-type]
    gate = Interlock()
    return SafetyWatch(store, gate), gate


def test_watch_reads_the_real_devices(tmp_path: Path) -> None:
    """Unknown before the first poll; Connected=true sent first; IsSafe and ShutterStatus decide; stopped,
    the monitor's last answer holds for unreachable_s, then it is unsafe."""
    with AlpacaSimulators(tmp_path) as sims:
        watch, gate = _watch(sims, monitor=sims.monitor_url, roof=sims.roof_url, poll_s=0.1, unreachable_s=1.0)
        assert gate.verdict.state is SafetyState.UNKNOWN and not gate.verdict.safe
        assert not sims.monitor_connected()
        verdict = watch.poll_once()
        assert sims.monitor_connected()
        assert (verdict.state, verdict.source, verdict.reason) == (
            SafetyState.UNSAFE, sims.roof_url, "ShutterStatus=1 (closed)")  # the simulator's roof starts closed
        sims.open_roof()
        verdict = watch.poll_once()
        assert verdict.state is SafetyState.SAFE and verdict.reason == "IsSafe=true, ShutterStatus=0 (open)"
        since = verdict.since
        assert watch.poll_once().since == since  # unchanged state: unchanged since
        sims.set_safe(False)
        verdict = watch.poll_once()
        assert (verdict.state, verdict.source, verdict.reason) == (SafetyState.UNSAFE, sims.monitor_url,
                                                                   "IsSafe=false")
        sims.set_safe(True)
        assert watch.poll_once().state is SafetyState.SAFE
        status = watch.status()
        assert status["monitor"]["answer"] == "IsSafe=true" and status["monitor"]["age_s"] < 1.0
        assert [e["kind"] for e in status["events"]] == ["unknown", "unsafe", "safe", "unsafe", "safe"]
    # The process is gone: the answers hold for unreachable_s, then the monitor counts as unsafe.
    gone = time.monotonic()
    assert watch.poll_once().state is SafetyState.SAFE
    assert "no answer" in watch.status()["monitor"]["error"]
    while time.monotonic() - gone < 1.2:
        time.sleep(0.1)
    verdict = watch.poll_once()
    assert verdict.state is SafetyState.UNSAFE and verdict.reason.startswith("no answer for"), verdict


def test_a_device_that_answers_errors_counts_as_unsafe_after_unreachable_s(tmp_path: Path) -> None:
    """safetymonitor/5 does not exist on the simulator (ErrorNumber 0x400): unknown, then unsafe."""
    with AlpacaSimulators(tmp_path) as sims:
        url = sims.monitor_url[:-1] + "5"
        watch, _gate = _watch(sims, monitor=url, poll_s=0.1, unreachable_s=0.5)
        assert watch.poll_once().state is SafetyState.UNKNOWN
        assert "0x400" in watch.status()["monitor"]["error"]
        time.sleep(0.6)
        verdict = watch.poll_once()
        assert verdict.state is SafetyState.UNSAFE and "0x400" in verdict.reason, verdict


def test_changing_the_urls_starts_afresh_and_emptying_them_turns_it_off(tmp_path: Path) -> None:
    with AlpacaSimulators(tmp_path) as sims:
        watch, _gate = _watch(sims, monitor=sims.monitor_url, poll_s=0.1, unreachable_s=5.0)
        assert watch.poll_once().state is SafetyState.SAFE
        watch.store.update(lambda s: dataclasses.replace(s, safety=SafetySettings(roof=sims.roof_url,
                                                                                  unreachable_s=5.0)))
        assert watch.poll_once().state is SafetyState.UNSAFE  # the roof, closed
        watch.store.update(lambda s: dataclasses.replace(s, safety=SafetySettings()))
        verdict = watch.poll_once()
        assert verdict.state is SafetyState.OFF and verdict.safe and verdict.since is None
