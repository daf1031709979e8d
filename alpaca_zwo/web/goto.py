"""Find an object, GoTo it, Sync on it: the page as a hand controller (issue 25 items 1 and 3).

``GET /setup/api/objects?q=`` searches, ``GET …/telescope/{n}/object?id=`` describes one object for the
site and the server's clock now, ``POST …/goto`` and ``POST …/sync`` point at it or sync on it. The
catalogue place becomes the mount's frame here (topocentric apparent, ``objects.apparent``); the
slew and the sync are then the Telescope's own SlewToCoordinatesAsync / SyncToCoordinates through
the facade, so the horizon limits, park state and every refusal are the Alpaca API's. The card's verdict
(``…/object``'s ``verdict``, ``GET …/goto/verdict?ra=&dec=``) is the check that GoTo runs first
(``DeviceFacade.goto_verdict``), so the page never says fine where the GoTo refuses. ``objects`` (and
with it PyEphem and OpenNGC) is imported on the first request, never at server start.
"""

from __future__ import annotations

import logging
import math
from datetime import datetime, timedelta, timezone
from types import ModuleType
from typing import TYPE_CHECKING, Any

import falcon

from ..facade import DeviceFacade, current_client
from .context import Resource
from .http import ApiError, api_errors, check_same_origin, iso, send

if TYPE_CHECKING:
    from ..catalogue.objects import Apparent, SiteZone, SkyObject

log = logging.getLogger(__name__)

SUN_WARNING = ("Pointing at the Sun without a certified solar filter over the telescope AND its finder blinds "
               "instantly and destroys cameras. Confirm only with a solar filter fitted.")
SYNC_WARNING = "Sync tells the mount it points at this object now: confirm only with the object centred."
PIER_SIDES = {0: "pierEast", 1: "pierWest", -1: "pierUnknown"}


def _objects() -> ModuleType:
    """The catalogues' module, imported on first use (it brings PyEphem and OpenNGC's database)."""
    from ..catalogue import objects

    return objects


def _time(t: datetime | None) -> str | None:
    return iso(t) if t is not None else None


def _site_time(t: datetime | None, zone: SiteZone) -> str | None:
    """The instant in the site's zone, with its offset: "2026-11-26T19:02:00+09:00"."""
    return t.astimezone(zone.zone).isoformat(timespec="seconds") if t is not None else None


def _query(req: falcon.Request, name: str) -> str:
    value = req.get_param(name)
    objects = _objects()
    if not isinstance(value, str) or not value.strip():
        raise ApiError(400, f"{name}: type a name or coordinates")
    if len(value) > objects.MAX_QUERY:
        raise ApiError(400, objects.TOO_LONG)
    return value


def _resolve(text: str) -> SkyObject:
    objects = _objects()
    try:
        found: SkyObject = objects.lookup(text)
        return found
    except objects.ObjectError as exc:
        raise ApiError(400 if isinstance(exc, objects.QueryError) else 404, str(exc)) from None


def _place(device: DeviceFacade, obj: SkyObject) -> Apparent:
    objects = _objects()
    lat, lon, elevation = device.site()
    place: Apparent = objects.apparent(obj, objects.Site(lat, lon, elevation), device.utc_now())
    return place


def _tonight(device: DeviceFacade, obj: SkyObject, zone: SiteZone) -> dict[str, Any]:
    """Tonight's plan in the site's clock: the dark window, the object's events in it in time order, its best
    time (``catalogue/tonight.py``)."""
    from ..catalogue import tonight

    lat, lon, elevation = device.site()
    night = tonight.tonight(obj, _objects().Site(lat, lon, elevation), device.utc_now())
    return {"start": _site_time(night.start, zone), "end": _site_time(night.end, zone), "dark": night.dark,
            "events": [{"what": name, "at": _site_time(at, zone)} for name, at in night.events],
            "best": _site_time(night.best, zone), "best_altitude": night.best_altitude}


def _moon_phase(device: DeviceFacade) -> dict[str, Any]:
    """The Moon's phase now: how much of it is lit and its name ("waxing crescent"), from PyEphem."""
    import ephem

    when = ephem.Date(device.utc_now().astimezone(timezone.utc).replace(tzinfo=None))
    moon = ephem.Moon(when)
    lit = float(moon.moon_phase) * 100.0
    waxing = ephem.next_full_moon(when) < ephem.next_new_moon(when)
    if lit < 3.0 or lit > 97.0:
        words = "new moon" if lit < 3.0 else "full moon"
    else:
        shape = "crescent" if lit < 47.0 else "quarter" if lit <= 53.0 else "gibbous"
        words = ("first " if waxing else "last ") + shape if shape == "quarter" else (
            "waxing " if waxing else "waning ") + shape
    return {"lit_percent": round(lit, 1), "waxing": waxing, "words": words}


#: How far ahead a target that is down is followed until it comes up, the step it is sampled at (a gap in
#: the horizon profile narrower than a step's turn of the sky can be missed) and how exactly the instant is found.
RISE_WITHIN = timedelta(hours=24)
RISE_STEP = timedelta(minutes=5)
RISE_EXACT = timedelta(seconds=10)


def rises_into_limits(device: DeviceFacade, obj: SkyObject, now: datetime) -> datetime | None:
    """The first instant within a day after ``now`` at which the object comes up into the allowed sky (the
    horizon profile, the minimum altitude, the mount's horizon and altitude limit: ``DeviceFacade.down_at``,
    GoTo's own check), having been under it just before: a target setting now waits for its next rise.
    None when it does not come up within the day. Moving bodies are followed along their path."""
    objects = _objects()
    site = objects.Site(*device.site())

    def down(at: datetime) -> bool:
        ra_hours, dec_deg = objects.apparent_radec(obj, site, at)
        return device.down_at(ra_hours, dec_deg, at)

    was_down, before = down(now), now
    for step in range(1, RISE_WITHIN // RISE_STEP + 1):
        at = now + RISE_STEP * step
        is_down = down(at)
        if was_down and not is_down:
            while at - before > RISE_EXACT:  # down at ``before``, up at ``at``: halve the gap
                middle = before + (at - before) / 2
                if down(middle):
                    before = middle
                else:
                    at = middle
            return at
        was_down, before = is_down, at
    return None


def _not_up(device: DeviceFacade, obj: SkyObject, place: Apparent, verdict: dict[str, Any], zone: SiteZone,
            now: datetime) -> dict[str, Any] | None:
    """What the GoTo button says instead of sending a slew that must be refused, when the target is under
    the allowed sky (None when it is not): "Not up: rises 00:28" in the site's clock (the minute it is up
    by), "Not up: never rises here", "Not up: never clears the limits here" (a fixed object whose highest
    is under them), "Not up tonight" (a moving body not up within a day)."""
    if not verdict.get("down"):
        return None
    rises = rises_into_limits(device, obj, now)
    if rises is not None:
        up_by = (rises + timedelta(seconds=59)).replace(second=0, microsecond=0)
        words = f"Not up: rises {up_by.astimezone(zone.zone):%H:%M}"
    elif place.never_up:
        words = "Not up: never rises here"
    elif obj.body is None:
        words = "Not up: never clears the limits here"
    else:
        words = "Not up tonight"
    return {"rises": _site_time(rises, zone), "words": words}


def describe(device: DeviceFacade, obj: SkyObject) -> dict[str, Any]:
    """What the page shows for a selection: the place now, whether a GoTo may go there, and how; the
    rise/transit/set instants in UTC and in the site's zone (``objects.site_zone``), with its name."""
    place = _place(device, obj)
    floor = device.horizon_floor(place.azimuth)
    verdict = device.goto_verdict(place.ra_hours, place.dec_deg)  # the GoTo's own check (POST …/goto)
    side = device.destination_side_of_pier(place.ra_hours, place.dec_deg)
    now = device.utc_now()
    latitude, longitude, _ = device.site()
    zone: SiteZone = _objects().site_zone(longitude, now, latitude=latitude)
    return {
        **obj.to_json(),
        "ra": place.ra_hours, "dec": place.dec_deg, "frame": "topocentric apparent (equinox of date)",
        "altitude": place.altitude, "azimuth": place.azimuth,
        "horizon_floor": floor, "above_limits": verdict["limit"] is None, "verdict": verdict,
        "rise": _time(place.rise), "transit": _time(place.transit), "set": _time(place.set),
        "site_zone": zone.label(now), "site_zone_source": zone.source, "site_zone_name": zone.name,
        "site_times": {"rise": _site_time(place.rise, zone), "transit": _site_time(place.transit, zone),
                       "set": _site_time(place.set, zone)},
        "tonight": _tonight(device, obj, zone),
        "not_up": _not_up(device, obj, place, verdict, zone, now),
        "phase": _moon_phase(device) if obj.body == "Moon" else None,
        "always_up": place.always_up, "never_up": place.never_up,
        "tracking_rate": obj.tracking_rate,
        "destination_side_of_pier": PIER_SIDES.get(side) if side is not None else None,
        "confirm": SUN_WARNING if obj.is_sun else None,
    }


class ObjectSearch(Resource):
    """``GET /setup/api/objects?q=``: matches, best first, whether the first is surely the one meant
    (the page's Enter takes only such a match) and a note for the person (ambiguous coordinates,
    satellites, a catalogue number OpenNGC lacks)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        with api_errors(resp):
            objects = _objects()
            try:
                found = objects.find(_query(req, "q"))
            except objects.ObjectError as exc:
                raise ApiError(400, str(exc)) from None
            send(resp, {"matches": [{**obj.to_json(), "matched": how} for obj, how in found.matches],
                        "confident": found.confident, "note": found.note})


class ObjectDetails(Resource):
    """``GET /setup/api/telescope/{number}/object?id=``: one object for this telescope's site and time."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            send(resp, describe(device, _resolve(_query(req, "id"))))


def _coordinate(req: falcon.Request, name: str, unit: str, low: float, high: float, example: str,
                high_included: bool) -> float:
    """One decimal coordinate of the query, in range: a clear 400 for anything else."""
    raw = req.get_param(name)
    if not isinstance(raw, str) or not raw.strip():
        raise ApiError(400, f"{name}: give {unit} as a decimal number, such as {name}={example}")
    try:
        value = float(raw) if len(raw) <= 40 and "_" not in raw else math.nan
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise ApiError(400, f"{name} must be {unit} as a decimal number, such as {name}={example}, "
                            f"not {raw[:40]!r}")
    if not (low <= value <= high) or (value == high and not high_included):
        span = f"{low:g} to {high:g}" if high_included else f"{low:g} to under {high:g}"
        raise ApiError(400, f"{name} {value:g} is outside {span} {unit}")
    return value


class GotoVerdict(Resource):
    """``GET /setup/api/telescope/{number}/goto/verdict?ra=&dec=``: would a GoTo to this RA (hours) and Dec
    (degrees), topocentric apparent of date as the object card gives them, be refused now, and by which
    limit? ``DeviceFacade.goto_verdict``: the check the GoTo itself runs first. The object card gets the
    same verdict in its description (``describe``)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            ra = _coordinate(req, "ra", "hours", 0.0, 24.0, "5.5881", False)
            dec = _coordinate(req, "dec", "degrees", -90.0, 90.0, "-5.391", True)
            send(resp, {"ra": ra, "dec": dec, **device.goto_verdict(ra, dec)})


class _Pointing(Resource):
    """A POST naming an object (``id``) and maybe ``confirm``; run as the page's own client."""

    verb = ""

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            device = self.web.device(number)
            raw = body.get("id")
            if not isinstance(raw, str) or not raw.strip() or len(raw) > _objects().MAX_QUERY:
                raise ApiError(400, "id must be an object id or name from the search")
            obj = _resolve(raw)
            confirm = body.get("confirm", False)
            if not isinstance(confirm, bool):
                raise ApiError(400, "confirm must be true or false")
            warning = self.warning(obj)
            if warning and not confirm:
                send(resp, {"error": "needs confirmation", "confirm": warning}, 409)
                return
            token = current_client.set(self.web.touch(req))
            try:
                place = _place(device, obj)
                self.act(device, obj, place)
            finally:
                current_client.reset(token)
            log.info("setup page (%s): %s %s at RA %.5f h Dec %.4f°", req.remote_addr, self.verb, obj.name,
                     place.ra_hours, place.dec_deg)
            send(resp, {"ok": True, **describe(device, obj)})

    def warning(self, obj: SkyObject) -> str | None:
        raise NotImplementedError

    def act(self, device: DeviceFacade, obj: SkyObject, place: Apparent) -> None:
        raise NotImplementedError


class GotoResource(_Pointing):
    """``POST /setup/api/telescope/{number}/goto``: the Sun only with ``confirm: true``."""

    verb = "GoTo"

    def warning(self, obj: SkyObject) -> str | None:
        return SUN_WARNING if obj.is_sun else None

    def act(self, device: DeviceFacade, obj: SkyObject, place: Apparent) -> None:
        device.goto(place.ra_hours, place.dec_deg, obj.tracking_rate)


class SyncResource(_Pointing):
    """``POST /setup/api/telescope/{number}/sync``: always with ``confirm: true``."""

    verb = "Sync"

    def warning(self, obj: SkyObject) -> str | None:
        return SYNC_WARNING

    def act(self, device: DeviceFacade, obj: SkyObject, place: Apparent) -> None:
        device.sync(place.ra_hours, place.dec_deg)
