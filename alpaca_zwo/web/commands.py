"""The page's controls: ``POST /setup/api/telescope/{number}/action/{name}``.

Every control goes through the same Telescope operations the Alpaca API uses (via the facade), run
as the page's own client, so the safety rules (limits, park state, MoveAxis watchdog) hold for both.
"""

from __future__ import annotations

import dataclasses
import json
import logging
from collections.abc import Callable
from datetime import datetime, timedelta, timezone
from typing import Any

import falcon

from .._exceptions import ERR_LINK, AlpacaError
from ..facade import DeviceFacade, TimeSetReport, current_client
from .context import Resource
from .http import ApiError, api_errors, check_same_origin, connect_trouble, flag, integer, iso, number, send

log = logging.getLogger(__name__)

Action = Callable[[DeviceFacade, dict[str, Any]], "dict[str, Any] | None"]


def _move(d: DeviceFacade, body: dict[str, Any]) -> None:
    axis = integer(body, "axis", 0, 1)
    d.move_axis(axis, number(body, "rate", -10.0, 10.0))


def _guide_rate(d: DeviceFacade, body: dict[str, Any]) -> None:
    d.set_guide_rate(number(body, "rate", 0.1, 0.9))


def _set_time(d: DeviceFacade, body: dict[str, Any]) -> dict[str, Any]:
    raw = body.get("utc")
    if not isinstance(raw, str):
        raise ApiError(400, "utc must be an ISO 8601 date and time, e.g. 2025-01-31T21:05:00.000Z")
    try:
        value = datetime.fromisoformat(raw.strip().replace("z", "Z").replace("Z", "+00:00"))
    except ValueError:
        raise ApiError(400, f"utc {raw!r} is not an ISO 8601 date and time") from None
    if value.tzinfo is None:
        raise ApiError(400, "utc must say its zone (end it with Z)")
    try:
        value = value.astimezone(timezone.utc)  # year 1 at +23:59 is before the first datetime
    except OverflowError:
        raise ApiError(400, f"utc {raw!r} is outside the years 1 to 9999 once converted to UTC") from None
    if "round_trip_ms" in body:  # the browser's send time, carried to when the request arrived
        try:
            value += timedelta(milliseconds=number(body, "round_trip_ms", 0, 60000) / 2.0)
        except OverflowError:
            raise ApiError(400, f"utc {raw!r} is outside the years 1 to 9999") from None
    return _time_report(d.set_time(value, "a browser on the setup page"))


def _time_report(report: TimeSetReport) -> dict[str, Any]:
    return {"utc": iso(report.utc), "mount_set": report.mount_set,
            "mount_utc": iso(report.mount_utc) if report.mount_utc else None,
            "mount_difference_s": None if report.mount_difference_s is None else round(report.mount_difference_s, 3)}


def _set_park(d: DeviceFacade, body: dict[str, Any]) -> dict[str, Any]:
    return {"park": dataclasses.asdict(d.set_park())}


def _connect(d: DeviceFacade, body: dict[str, Any]) -> None:
    """Connect; a mount not found is said as where it was looked for and what to check."""
    try:
        d.set_connected(True)
    except AlpacaError as exc:
        if exc.number != ERR_LINK:
            raise
        log.warning("setup page: connecting failed: %s", exc.message)
        raise ApiError(409, connect_trouble(d.url)) from None


ACTIONS: dict[str, Action] = {
    "connect": _connect,
    "disconnect": lambda d, body: d.set_connected(False),
    "abort": lambda d, body: d.abort(),
    "move": _move,
    "park": lambda d, body: d.park(),
    "unpark": lambda d, body: d.unpark(),
    "find_home": lambda d, body: d.find_home(),
    "set_park": _set_park,
    "tracking": lambda d, body: d.set_tracking(flag(body, "on")),
    "tracking_rate": lambda d, body: d.set_tracking_rate(integer(body, "rate", 0, 2)),
    "guide_rate": _guide_rate,
    "time": _set_time,
}


class ActionResource(Resource):
    """Runs one control as the page's client (its own key, so connection and MoveAxis are tracked)."""

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str, name: str) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            device = self.web.device(number)
            handler = ACTIONS.get(name)
            if handler is None:
                raise ApiError(404, f"unknown action {name!r}; actions: {', '.join(sorted(ACTIONS))}")
            key = self.web.touch(req)
            token = current_client.set(key)
            try:
                result = handler(device, body)
            finally:
                current_client.reset(token)
            if name != "move" or body.get("rate"):
                log.info("setup page (%s): %s %s", req.remote_addr, name, json.dumps(body) if body else "")
            send(resp, {"ok": True, **(result or {})})
