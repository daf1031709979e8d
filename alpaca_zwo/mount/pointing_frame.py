"""The pointing model as the mount layer applies it: between the mount's frame and the client's.

The mount keeps doing its own single-point sync (``:CM#`` shifts its readings by a constant, the
alignment offset ``a`` Mount tracks), so a sync still reads back exactly what was synced and a mount
with the model switched off, cleared or holding one point behaves exactly as before. On top of it
this adds the model's shape::

    client = reading + D(m) − D(A) − (1 − w)·e(A)       m = reading − a: where the axes point, unsynced

where ``D(m)`` is the model's true-minus-mechanical offset at ``m`` (pointing_model.py, TPoint's terms),
``A`` the last sync's point, ``e(A)`` its residual against the model and ``w`` a weight that is 1 at
``A`` and fades with the distance from it (ANCHOR_REACH_DEG; 0 on the other pier side). At the sync the
correction is zero, so the read-back is exact; near it the sync's own residual holds (a re-centring lands
on it); far from it the reading is the model's prediction alone, so one sync with an unmodelled error
(or a refused, wrong one) does not shift the whole sky (alpaca-benro-polaris weighs nearby syncs likewise).
After a mount restart or ``:NSC#`` the mount
reads ``m`` itself and there is no anchor: the whole model (index errors included) applies, so a
model fitted last night points the mount right after a power cycle without a sync.

The model file (JSON, beside the configuration) holds the points, the switch, the site and mode they
belong to, and the mount's alignment offset and anchor, which a server restart must not forget while
the mount keeps its sync (a mount restart drops both: Mount._check_restart).
"""

from __future__ import annotations

import json
import logging
import math
import os
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import sky
from .pointing_model import (
    Fit,
    ModelPoint,
    Place,
    PointingModel,
    PointVerdict,
    point_from_dict,
    point_to_dict,
    separation_deg,
    to_true,
)

log = logging.getLogger(__name__)

#: How far (degrees on the sky) the last sync's own residual reaches: it is kept in full at the sync (a
#: sync reads back exactly) and fades as exp(−(d/ANCHOR_REACH_DEG)²), so far from it the model alone
#: applies (alpaca-benro-polaris weighs nearby syncs likewise). A re-centring is a fraction of a degree
#: away: there the sync holds to a hundredth of an arcsecond per arcminute of residual.
ANCHOR_REACH_DEG = 15.0
#: A site this far (degrees of latitude or longitude, about a kilometre) from the model's is another
#: set-up: the model starts afresh (docs/pointing-model.md).
SITE_CHANGE_DEG = 0.01


@dataclass(frozen=True)
class Sky:
    """Where things are when a position is judged: the local sidereal time (hours), the pointing
    state's sign (+1 normal / alt-az, −1 through the pole) and the mount's alignment offset."""

    lst: float
    side: int
    alignment: tuple[float, float]


def side_sign(pier_side: sky.PierSide, latitude: float) -> int:
    """TPoint's pier sign for an ASCOM pointing state: −1 with the Dec axis through the pole (TPoint's
    mechanical Dec beyond ±90°), which is pierEast north of the equator (and on it) and pierWest south
    of it, as the emulator's axes are (emulator/state.py, Hemisphere.outer); else +1."""
    outer = sky.PierSide.EAST if latitude >= 0.0 else sky.PierSide.WEST
    return -1 if pier_side is outer else 1


class PointingFrame:
    """One mount's pointing model, its anchor and its file; every method is thread-safe."""

    def __init__(self, path: Path | None = None) -> None:
        self._path = path
        self._lock = threading.Lock()
        self._model = PointingModel()
        self._anchor: ModelPoint | None = None
        self._longitude: float | None = None
        self.saved_alignment: tuple[float, float] = (0.0, 0.0)
        self._load()

    # -- applying ---------------------------------------------------------------------------

    def _place(self, ha_h: float, dec: float, side: int) -> Place:
        """The model's frame: (HA°, Dec) with the pier sign, or alt-az in TPoint's azimuth (zero due
        south, 90° east: A = 180° − azimuth), whose AN/AW signs are defined in it."""
        if self._model.altaz:
            alt, az = sky.equatorial_to_horizontal(ha_h, dec, self._model.latitude)
            return Place((180.0 - az) % 360.0, alt, 1)
        return Place((ha_h * 15.0) % 360.0, dec, side)

    def _hadec(self, place: Place) -> tuple[float, float]:
        if self._model.altaz:
            return sky.horizontal_to_equatorial(place.lat, (180.0 - place.lon) % 360.0, self._model.latitude)
        return place.lon / 15.0, place.lat

    def _offset(self, model: Fit, mech: Place) -> tuple[float, float]:
        """(ΔRA hours, ΔDec degrees), true minus mechanical, the model predicts at ``mech``."""
        if not model.terms:
            return 0.0, 0.0
        mech_ha, mech_dec = self._hadec(mech)
        true_ha, true_dec = self._hadec(to_true(model, mech, self._model.latitude, self._model.altaz))
        return -sky.wrap_hours_12(true_ha - mech_ha), true_dec - mech_dec

    def _measured(self, point: ModelPoint) -> tuple[float, float]:
        """(ΔRA hours, ΔDec degrees), true minus mechanical, as a sync measured it."""
        mech_ha, mech_dec = self._hadec(point.mech)
        true_ha, true_dec = self._hadec(point.true)
        return -sky.wrap_hours_12(true_ha - mech_ha), true_dec - mech_dec

    def _correction(self, model: Fit, ra: float, dec: float, where: Sky) -> tuple[float, float]:
        """D(m) − D(anchor) − (1 − w)·e(anchor) for a mount-frame position: the model's shape on the
        mount's own sync, the last sync's residual e kept near it and faded far from it (w, the module
        docstring and ANCHOR_REACH_DEG)."""
        if not model.terms:
            return 0.0, 0.0
        mech_ra, mech_dec = ra - where.alignment[0], max(-90.0, min(90.0, dec - where.alignment[1]))
        mech = self._place(sky.hour_angle(where.lst, mech_ra), mech_dec, where.side)
        d_ra, d_dec = self._offset(model, mech)
        anchor = self._anchor
        if anchor is None:
            return d_ra, d_dec
        a_ra, a_dec = self._offset(model, anchor.mech)
        m_ra, m_dec = self._measured(anchor)
        fade = 1.0
        if anchor.mech.side == mech.side:
            fade -= math.exp(-((separation_deg(mech, anchor.mech) / ANCHOR_REACH_DEG) ** 2))
        return (d_ra - a_ra - fade * sky.wrap_hours_12(m_ra - a_ra),
                d_dec - a_dec - fade * (m_dec - a_dec))

    @property
    def applies(self) -> bool:
        """Whether the model corrects anything now (switched on, with terms): callers skip the rest if not."""
        return bool(self._model.active.terms)

    def to_client(self, ra: float, dec: float, where: Sky) -> tuple[float, float]:
        """A mount-frame reading corrected by the model (still without the sync remainder)."""
        with self._lock:
            d_ra, d_dec = self._correction(self._model.active, ra, dec, where)
        return (ra + d_ra) % 24.0, max(-90.0, min(90.0, dec + d_dec))

    def to_mount(self, ra: float, dec: float, where: Sky) -> tuple[float, float]:
        """The mount-frame position that reads as ``(ra, dec)`` once corrected (to_client iterated)."""
        with self._lock:
            model = self._model.active
            mount = (ra, dec)
            for _ in range(10):
                d_ra, d_dec = self._correction(model, mount[0], mount[1], where)
                nxt = ((ra - d_ra) % 24.0, max(-90.0, min(90.0, dec - d_dec)))
                moved = abs(sky.wrap_hours_12(nxt[0] - mount[0])) * 15.0 + abs(nxt[1] - mount[1])
                mount = nxt
                if moved < 1e-4 / 3600.0:
                    break
        return mount

    # -- learning -----------------------------------------------------------------------------

    def add_sync(self, before: tuple[float, float] | None, synced: tuple[float, float], where: Sky,
                 when: str, anchors: bool = True) -> PointVerdict:
        """A sync from mount-frame position ``before`` (``where.alignment`` the offset before it) to
        ``synced``: a point for the model, and the new anchor unless ``anchors`` is false (a sync the
        mount was not sent, as it already agreed: its own offset still belongs to the last one). None
        ``before``: no reading to learn from."""
        with self._lock:
            if before is None:
                if anchors:
                    self._anchor = None
                    self._save()
                return PointVerdict(False, message="no reading before the sync: nothing learnt")
            mech_ra = before[0] - where.alignment[0]
            mech_dec = max(-90.0, min(90.0, before[1] - where.alignment[1]))
            mech = self._place(sky.hour_angle(where.lst, mech_ra), mech_dec, where.side)
            true = self._place(sky.hour_angle(where.lst, synced[0]), synced[1], where.side)
            point = ModelPoint(mech, true, when, synced[0] % 24.0, synced[1])
            verdict = self._model.add(point)
            if anchors:
                self._anchor = point
            self._save()
        if not verdict.accepted:
            log.warning("%s", verdict.message)
        return verdict

    def mount_forgot(self) -> None:
        """The mount restarted or forgot its syncs (``:NSC#``): no alignment offset, no anchor."""
        with self._lock:
            self._anchor = None
            self.saved_alignment = (0.0, 0.0)
            self._save()

    def note_alignment(self, alignment: tuple[float, float]) -> None:
        """The mount's alignment offset after a sync, kept for a server restart."""
        with self._lock:
            self.saved_alignment = alignment
            self._save()

    def set_site(self, latitude: float, longitude: float, altaz: bool) -> None:
        """The site and mode in force: another set-up (more than SITE_CHANGE_DEG away, or the other
        mode) starts an empty model; a refinement of the same site keeps it."""
        with self._lock:
            moved = self._longitude is not None and abs(sky.wrap_hours_12((longitude - self._longitude) / 15.0)) \
                * 15.0 >= SITE_CHANGE_DEG
            same = (not moved and abs(latitude - self._model.latitude) < SITE_CHANGE_DEG
                    and altaz == self._model.altaz)
            if not same and self._model.points:
                log.warning("pointing model cleared: the site or the mount's mode changed")
            if not same:
                self._anchor = None
                self._model = PointingModel(latitude, altaz, self._model.enabled)
            self._longitude = longitude
            self._save()

    def clear(self) -> None:
        with self._lock:
            self._model.clear()
            self._save()

    def set_enabled(self, enabled: bool) -> None:
        with self._lock:
            self._model.enabled = enabled
            self._save()

    @property
    def enabled(self) -> bool:
        return self._model.enabled

    def report(self) -> dict[str, Any]:
        """Everything a person needs to judge the model: points with residuals, terms ± σ, RMS."""
        with self._lock:
            model = self._model
            solution = model.solution
            points = [{"ra_h": p.ra_h, "dec_deg": p.dec_deg, "time": p.time, "pier": p.mech.side,
                       **self._where_taken(p.true), "residual_arcsec": [round(r[0], 1), round(r[1], 1)]}
                      for p, r in zip(model.points, solution.residuals, strict=False)]
            return {
                "enabled": model.enabled,
                "mode": "altaz" if model.altaz else "equatorial",
                "latitude": model.latitude,
                "points": points,
                "terms": [{"name": t.name, "arcsec": round(t.value, 1),
                           "sigma_arcsec": None if t.sigma is None else round(t.sigma, 1)} for t in solution.terms],
                "rms_arcsec": round(solution.rms, 1),
                "last_refusal": model.last_refusal,
            }

    def _where_taken(self, true: Place) -> dict[str, float]:
        """Where on the local sky a point was taken (its hour angle fixes it there): the page's chart."""
        ha, dec = self._hadec(true)
        alt, az = sky.equatorial_to_horizontal(ha, dec, self._model.latitude)
        return {"alt": round(alt, 2), "az": round(az, 2)}

    # -- the file -------------------------------------------------------------------------------

    def _load(self) -> None:
        if self._path is None or not self._path.exists():
            return
        try:
            data = json.loads(self._path.read_text(encoding="utf-8"))
            self._model = PointingModel.from_dict(data["model"])
            self._longitude = None if data.get("longitude") is None else float(data["longitude"])
            alignment = data.get("alignment", [0.0, 0.0])
            self.saved_alignment = (float(alignment[0]), float(alignment[1]))
            anchor = data.get("anchor")
            self._anchor = None if anchor is None else point_from_dict(anchor)
        except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
            log.error("pointing model file %s not read (%s): starting without a model", self._path, exc)

    def _save(self) -> None:
        """Write the file atomically (a crash leaves the old one); a failure is logged, not raised:
        pointing goes on with the model in memory."""
        if self._path is None:
            return
        anchor = None if self._anchor is None else point_to_dict(self._anchor)
        data = {"model": self._model.to_dict(), "longitude": self._longitude,
                "alignment": list(self.saved_alignment), "anchor": anchor}
        try:
            self._path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=self._path.name, suffix=".tmp", dir=self._path.parent)
            with os.fdopen(fd, "w", encoding="utf-8") as handle:
                json.dump(data, handle, indent=1)
            os.replace(tmp, self._path)
        except OSError as exc:
            log.error("pointing model not saved to %s: %s", self._path, exc)
