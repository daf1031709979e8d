"""What the page's chart draws of the sky: stars, constellation lines, Sun, Moon and planets (issue 25 item 2).

``GET /setup/api/telescope/{n}/sky`` answers the alt/az of every star in ``sky_data.json`` (to V 4.5 and
the constellation figures' fainter stars, built by tools/make_sky_data.py) and of the solar-system
bodies, for the telescope's site and the server's clock now. Positions are PyEphem's topocentric
apparent places, the same frame and library as the GoTo (``objects.apparent``), so a star's dot is where
a GoTo on it would point. No serial traffic and ~2 ms a call; the page asks every ~30 s. PyEphem is
imported on the first request, never at server start.
"""

from __future__ import annotations

import json
import math
import threading
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path
from typing import Any

import falcon

from .context import Resource
from .http import ApiError, api_errors, iso, send

DATA = Path(__file__).with_name("sky_data.json")
BODIES = ("Sun", "Moon", "Mercury", "Venus", "Mars", "Jupiter", "Saturn", "Uranus", "Neptune")


@lru_cache(maxsize=1)
def catalogue() -> dict[str, Any]:
    """The stars ([hip, ra°, dec°, vmag, name|null], brightest first) and lines (index pairs)."""
    data: dict[str, Any] = json.loads(DATA.read_text(encoding="utf-8"))
    return data


def _fixed_bodies() -> list[Any]:
    import ephem

    bodies = []
    for _hip, ra, dec, _mag, _name in catalogue()["stars"]:
        star = ephem.FixedBody()
        star._ra, star._dec = math.radians(ra), math.radians(dec)
        star._epoch = ephem.J2000
        bodies.append(star)
    return bodies


_stars_lock = threading.Lock()
_star_bodies: list[Any] = []


def sky_now(latitude: float, longitude: float, elevation: float, when: datetime) -> dict[str, Any]:
    """Alt/az (degrees, 0.01°) of the catalogue's stars (in its order) and of the bodies, at ``when``."""
    from .objects import Site, _observer

    obs = _observer(Site(latitude, longitude, elevation), when)
    stars = []
    with _stars_lock:  # PyEphem bodies hold their last computation: one request at a time uses them
        if not _star_bodies:
            _star_bodies.extend(_fixed_bodies())
        for body in _star_bodies:
            body.compute(obs)
            stars.append([round(math.degrees(float(body.alt)), 2), round(math.degrees(float(body.az)) % 360.0, 2)])
    import ephem

    bodies = []
    for name in BODIES:
        body = getattr(ephem, name)()
        body.compute(obs)
        bodies.append({"id": f"body:{name}", "name": name, "alt": round(math.degrees(float(body.alt)), 3),
                       "az": round(math.degrees(float(body.az)) % 360.0, 3), "mag": round(float(body.mag), 1),
                       "phase": round(float(body.phase), 1) if name == "Moon" else None})
    return {"time": iso(when), "latitude": latitude, "stars": stars, "bodies": bodies}


class SkyResource(Resource):
    """``GET /setup/api/telescope/{number}/sky``: the chart's stars and bodies now (``?catalogue=1`` adds
    the star list and lines, which never change: the page asks for them once)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            flag = req.get_param("catalogue")
            if flag not in (None, "true", "false", "1", "0"):
                raise ApiError(400, "catalogue must be true or false")
            body = sky_now(*device.site(), device.utc_now().astimezone(timezone.utc))  # ~2 ms for 1000 stars
            if flag in ("true", "1"):
                data = catalogue()
                body["catalogue"] = {"stars": data["stars"], "lines": data["lines"], "source": data["source"]}
            send(resp, body)
