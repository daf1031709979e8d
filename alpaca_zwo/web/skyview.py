"""What the page's chart draws of the sky: stars, constellation lines, deep-sky objects, Sun, Moon and
planets (issue 25 item 2, issue 33 item 6).

``GET /setup/api/telescope/{n}/sky`` answers the alt/az of every star in ``sky_data.json`` (to V 4.5 and
the constellation figures' fainter stars, built by tools/make_sky_data.py), of the deep-sky objects the
chart draws (the Messier and Caldwell lists and anything brighter than V 5, from OpenNGC:
``deepsky.chart_objects``) and of the solar-system bodies, for the telescope's site and the server's
clock now. Positions are PyEphem's topocentric apparent places, the same frame and library as the GoTo
(``objects.apparent``), so a dot is where a GoTo on it would point. No serial traffic and a few ms a
call; the page asks every ~30 s. PyEphem and OpenNGC are imported on the first request, never at server start.
"""

from __future__ import annotations

import json
import math
import threading
from datetime import datetime, timezone
from functools import lru_cache
from typing import Any

import falcon

from .context import Resource
from .http import ApiError, api_errors, iso, send

BODIES = ("Sun", "Moon", "Mercury", "Venus", "Mars", "Jupiter", "Saturn", "Uranus", "Neptune")


@lru_cache(maxsize=1)
def catalogue() -> dict[str, Any]:
    """The stars ([hip, ra°, dec°, vmag, name|null, designations, pm RA, pm Dec], brightest first) and the
    lines (index pairs)."""
    from ..catalogue import data_text

    data: dict[str, Any] = json.loads(data_text("sky_data.json"))
    return data


@lru_cache(maxsize=1)
def deep_sky() -> list[list[Any]]:
    """The chart's deep-sky objects: [id, name, label, kind, shape, ra°, dec°, mag|null, size°], brightest
    first (none without pyongc)."""
    from ..catalogue.deepsky import chart_objects

    return [[c.obj.id, c.obj.name, c.label, c.obj.kind, c.shape, round((c.obj.ra_hours or 0.0) * 15.0, 4),
             round(c.obj.dec_deg or 0.0, 4), None if c.obj.magnitude is None else round(c.obj.magnitude, 1),
             c.size_deg] for c in chart_objects()]


def _fixed_bodies(places: list[tuple[float, float]]) -> list[Any]:
    import ephem

    bodies = []
    for ra, dec in places:
        star = ephem.FixedBody()
        star._ra, star._dec = math.radians(ra), math.radians(dec)
        star._epoch = ephem.J2000
        bodies.append(star)
    return bodies


_bodies_lock = threading.Lock()
_star_bodies: list[Any] = []
_dso_bodies: list[Any] = []


def _altaz(bodies: list[Any], obs: Any) -> list[list[float]]:
    places = []
    for body in bodies:
        body.compute(obs)
        places.append([round(math.degrees(float(body.alt)), 2), round(math.degrees(float(body.az)) % 360.0, 2)])
    return places


def sky_now(latitude: float, longitude: float, elevation: float, when: datetime) -> dict[str, Any]:
    """Alt/az (degrees, 0.01°) of the catalogue's stars and deep-sky objects (in their order) and of the
    bodies, at ``when``."""
    from ..catalogue.objects import Site, observer

    obs = observer(Site(latitude, longitude, elevation), when)
    with _bodies_lock:  # PyEphem bodies hold their last computation: one request at a time uses them
        if not _star_bodies:
            _star_bodies.extend(_fixed_bodies([(s[1], s[2]) for s in catalogue()["stars"]]))
            _dso_bodies.extend(_fixed_bodies([(d[5], d[6]) for d in deep_sky()]))
        stars = _altaz(_star_bodies, obs)
        dsos = _altaz(_dso_bodies, obs)
    import ephem

    bodies = []
    for name in BODIES:
        body = getattr(ephem, name)()
        body.compute(obs)
        bodies.append({"id": f"body:{name}", "name": name, "alt": round(math.degrees(float(body.alt)), 3),
                       "az": round(math.degrees(float(body.az)) % 360.0, 3), "mag": round(float(body.mag), 1),
                       "phase": round(float(body.phase), 1) if name == "Moon" else None})
    return {"time": iso(when), "latitude": latitude, "stars": stars, "dsos": dsos, "bodies": bodies}


class SkyResource(Resource):
    """``GET /setup/api/telescope/{number}/sky``: the chart's stars, deep-sky objects and bodies now
    (``?catalogue=1`` adds the star and deep-sky lists and the lines, which never change: the page asks
    for them once)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            flag = req.get_param("catalogue")
            if flag not in (None, "true", "false", "1", "0"):
                raise ApiError(400, "catalogue must be true or false")
            body = sky_now(*device.site(), device.utc_now().astimezone(timezone.utc))  # ~2 ms for 1000 stars
            if flag in ("true", "1"):
                data = catalogue()
                body["catalogue"] = {"stars": data["stars"], "lines": data["lines"], "source": data["source"],
                                     "dsos": deep_sky()}
            send(resp, body)
