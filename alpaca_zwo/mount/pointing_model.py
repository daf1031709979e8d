"""A pointing model of the mount's mechanical errors, fitted to its syncs (issue 40).

A real mount's axes do not point where their encoders say: the polar axis is a few arcminutes off
the pole, the tube is not square to the Dec axis, the home position is off, tubes flex. One sync
removes only a constant offset; this module fits the classic TPoint terms (P. T. Wallace's
definitions and signs, as INDI's SPK pointing kernel, INDI PR #2376, and OnStepX use them) to every
sync by least squares, so a GoTo across the sky lands where the model predicts.

Conventions (TPoint's): each term gives *mechanical minus true*, ``ΔH = H_mech − H_true`` and
``Δδ = δ_mech − δ_true`` (alt-az: ``ΔA``, ``ΔE``), evaluated at the mechanical position.

Equatorial (h hour angle, δ declination, φ latitude; s = −1 with the Dec axis through the pole,
where TPoint's mechanical δ is beyond ±90°, and +1 on the other side: CH, NP and ID change sign
across the flip because the Dec axis is turned over; which ASCOM side that is: pointing_frame.side_sign)::

    IH  ΔH = −IH                     ID  Δδ = −s·ID
    CH  ΔH = −s·CH·sec δ             NP  ΔH = −s·NP·tan δ
    MA  ΔH = −MA·cos h·tan δ         Δδ = +MA·sin h
    ME  ΔH = +ME·sin h·tan δ         Δδ = +ME·cos h
    TF  ΔH = +TF·cos φ·sin h·sec δ   Δδ = +TF·(cos φ·cos h·sin δ − sin φ·cos δ)

Alt-az (A TPoint's azimuth, zero due south and 90° east, E elevation)::

    IA  ΔA = −IA                     IE  ΔE = +IE
    CA  ΔA = −CA·sec E               NPAE ΔA = −NPAE·tan E
    AN  ΔA = −AN·sin A·tan E         ΔE = −AN·cos A
    AW  ΔA = −AW·cos A·tan E         ΔE = +AW·sin A
    TF  ΔE = −TF·cos E

Terms enter as the points can determine them (as INDI's SPK adds terms as points grow): one
point fixes only the two index errors; from then on a group of terms is admitted while the fit
keeps an equation to spare (2·n ≥ terms + 1: three points fit five terms, four all seven), in the
order of their usual size on a portable mount (index errors, then the polar axis, then collimation,
which a meridian flip doubles, then non-perpendicularity, then flexure),
and a term whose uncertainty the points' geometry would inflate more than ``CONDITION_LIMIT``
times (CH and NP with every point on one pier side in a narrow band: they then look like IH) is left out. Pure: no
I/O, no clock, no threads; the mount layer (operations.py) owns the instance, its lock and its file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from .. import sky

ARCSEC_PER_DEG = 3600.0
#: Adoption order: groups enter together (a pair of terms is what a pair of new equations buys).
EQUATORIAL_GROUPS: tuple[tuple[str, ...], ...] = (("IH", "ID"), ("MA", "ME"), ("CH",), ("NP",), ("TF",))
ALTAZ_GROUPS: tuple[tuple[str, ...], ...] = (("IA", "IE"), ("AN", "AW"), ("CA",), ("NPAE",), ("TF",))
#: Equations a fit keeps to spare beyond one point's exact index pair (an RMS and σ need at least one).
SPARE_EQUATIONS = 1
#: A term is left out when the points' geometry inflates its σ more than this many times over what
#: the same number of ideally spread points would give (σ·√n / scatter, a variance inflation): CH
#: beside IH and NP with every point on one pier side in a narrow band of declination, say. Not
#: tighter: a term known to an arcminute still beats leaving out a term several arcminutes large.
CONDITION_LIMIT = 30.0
#: A new point this close (degrees, same pier side) to an existing one replaces it (GS Server's 0.5°).
NEAR_DEG = 0.5
#: A point missing the model by more than max(OUTLIER_RMS × RMS, OUTLIER_FLOOR_ARCSEC) is refused,
#: once the model has MIN_POINTS_FOR_OUTLIERS points, OUTLIER_SIDE_POINTS of them on its pier side.
OUTLIER_RMS = 5.0
OUTLIER_FLOOR_ARCSEC = 20.0 * 60.0
MIN_POINTS_FOR_OUTLIERS = 4
OUTLIER_SIDE_POINTS = 2
#: The oldest points go beyond this many (a night's syncs; the fit stays a few milliseconds).
MAX_POINTS = 60
_MAX_SEC_DEG = 89.9  # sec/tan are evaluated no nearer the pole than this (TPoint's terms diverge there)


@dataclass(frozen=True)
class Place:
    """A position in the model's own frame: equatorial (hour angle, declination) or alt-az (azimuth,
    elevation), in degrees, with the pier side sign (+1 normal / alt-az, −1 through the pole)."""

    lon: float
    lat: float
    side: int = 1


@dataclass(frozen=True)
class ModelPoint:
    """One sync: where the axes said they pointed (``mech``) and where the sky says they did (``true``)."""

    mech: Place
    true: Place
    time: str = ""  # ISO UTC, for people reading the list
    ra_h: float = 0.0  # the synced RA/Dec, for the page's chart
    dec_deg: float = 0.0

    def error(self) -> tuple[float, float]:
        """(mechanical − true) as (x on the sky, y) in arcseconds: x = ΔH·cos δ (ΔA·cos E)."""
        d_lon = (self.mech.lon - self.true.lon + 180.0) % 360.0 - 180.0
        return (d_lon * math.cos(math.radians(self.mech.lat)) * ARCSEC_PER_DEG,
                (self.mech.lat - self.true.lat) * ARCSEC_PER_DEG)


def _sec_tan(lat_deg: float) -> tuple[float, float, float, float]:
    """(sin, cos, sec, tan) of a latitude, sec and tan held finite near the pole."""
    rad = math.radians(lat_deg)
    clamped = math.radians(max(-_MAX_SEC_DEG, min(_MAX_SEC_DEG, lat_deg)))
    return math.sin(rad), math.cos(rad), 1.0 / math.cos(clamped), math.tan(clamped)


def _equatorial_partials(name: str, at: Place, latitude: float) -> tuple[float, float]:
    """(ΔH, Δδ) per unit of the term, at a mechanical place (TPoint's definitions, module docstring)."""
    h = math.radians(at.lon)
    sin_d, cos_d, sec_d, tan_d = _sec_tan(at.lat)
    sin_h, cos_h = math.sin(h), math.cos(h)
    cos_p, sin_p = math.cos(math.radians(latitude)), math.sin(math.radians(latitude))
    s = float(at.side)
    table = {
        "IH": (-1.0, 0.0),
        "ID": (0.0, -s),
        "CH": (-s * sec_d, 0.0),
        "NP": (-s * tan_d, 0.0),
        "MA": (-cos_h * tan_d, sin_h),
        "ME": (sin_h * tan_d, cos_h),
        "TF": (cos_p * sin_h * sec_d, cos_p * cos_h * sin_d - sin_p * cos_d),
    }
    return table[name]


def _altaz_partials(name: str, at: Place, latitude: float) -> tuple[float, float]:
    """(ΔA, ΔE) per unit of the term, at a mechanical place (TPoint's alt-az definitions)."""
    a = math.radians(at.lon)
    _, cos_e, sec_e, tan_e = _sec_tan(at.lat)
    sin_a, cos_a = math.sin(a), math.cos(a)
    table = {
        "IA": (-1.0, 0.0),
        "IE": (0.0, 1.0),
        "CA": (-sec_e, 0.0),
        "NPAE": (-tan_e, 0.0),
        "AN": (-sin_a * tan_e, -cos_a),
        "AW": (-cos_a * tan_e, sin_a),
        "TF": (0.0, -cos_e),
    }
    return table[name]


def partials(name: str, at: Place, latitude: float, altaz: bool) -> tuple[float, float]:
    """One term's (Δlon, Δlat) per unit coefficient at ``at``: what the fit and the application share."""
    return (_altaz_partials if altaz else _equatorial_partials)(name, at, latitude)


def _row(names: tuple[str, ...], at: Place, latitude: float, altaz: bool) -> tuple[list[float], list[float]]:
    """The design matrix's two rows for one place: x = Δlon·cos(lat) (on the sky) and y = Δlat."""
    cos_lat = math.cos(math.radians(at.lat))
    xs: list[float] = []
    ys: list[float] = []
    for name in names:
        d_lon, d_lat = partials(name, at, latitude, altaz)
        xs.append(d_lon * cos_lat)
        ys.append(d_lat)
    return xs, ys


def _invert(matrix: list[list[float]]) -> list[list[float]] | None:
    """Gauss-Jordan inverse with partial pivoting; None when singular (a term the points cannot see)."""
    n = len(matrix)
    work = [row[:] + [1.0 if i == j else 0.0 for j in range(n)] for i, row in enumerate(matrix)]
    scale = max((abs(v) for row in matrix for v in row), default=1.0) or 1.0
    for col in range(n):
        pivot = max(range(col, n), key=lambda r: abs(work[r][col]))
        if abs(work[pivot][col]) <= 1e-12 * scale:
            return None
        work[col], work[pivot] = work[pivot], work[col]
        lead = work[col][col]
        work[col] = [v / lead for v in work[col]]
        for r in range(n):
            if r != col and work[r][col] != 0.0:
                factor = work[r][col]
                work[r] = [a - factor * b for a, b in zip(work[r], work[col], strict=True)]
    return [row[n:] for row in work]


@dataclass(frozen=True)
class Term:
    """A fitted term: value and 1σ uncertainty in arcseconds (None: no spare equation to judge it)."""

    name: str
    value: float
    sigma: float | None


@dataclass(frozen=True)
class Fit:
    """A least-squares solution: the terms, each point's residual (x, y arcsec) and the RMS (arcsec).

    ``one_side``: the pier sign of every point when all were taken on one side (0: both sides seen).
    Such a fit cannot tell ID, CH and NP from offsets that do not flip (on one side ID is any constant
    Dec offset), so it applies them on both sides as measured, as a single sync does, instead of
    flipping a guess; the first point on the other side then lets them flip as TPoint defines.
    """

    terms: tuple[Term, ...] = ()
    residuals: tuple[tuple[float, float], ...] = ()
    rms: float = 0.0
    one_side: int = 0

    def value(self, name: str) -> float:
        return next((t.value for t in self.terms if t.name == name), 0.0)


def _solve(names: tuple[str, ...], points: list[ModelPoint], latitude: float, altaz: bool
           ) -> tuple[list[float], list[list[float]]] | None:
    """Coefficients and (AᵀA)⁻¹ for ``names``; None if the normal equations are singular."""
    k = len(names)
    normal = [[0.0] * k for _ in range(k)]
    rhs = [0.0] * k
    for point in points:
        ex, ey = point.error()
        for row, obs in zip(_row(names, point.mech, latitude, altaz), (ex, ey), strict=True):
            for i in range(k):
                rhs[i] += row[i] * obs
                for j in range(k):
                    normal[i][j] += row[i] * row[j]
    inverse = _invert(normal)
    if inverse is None:
        return None
    return [sum(inverse[i][j] * rhs[j] for j in range(k)) for i in range(k)], inverse


def candidate_terms(count: int, altaz: bool) -> tuple[str, ...]:
    """The terms ``count`` points may determine: the index pair from one point, then whole groups
    while SPARE_EQUATIONS stay spare (2·count ≥ terms + SPARE_EQUATIONS)."""
    if count <= 0:
        return ()
    names: tuple[str, ...] = ()
    for group in ALTAZ_GROUPS if altaz else EQUATORIAL_GROUPS:
        if names and 2 * count < len(names) + len(group) + SPARE_EQUATIONS:
            break
        names += group
    return names


def _determined(names: tuple[str, ...], points: list[ModelPoint], latitude: float, altaz: bool
                ) -> tuple[tuple[str, ...], list[float], list[list[float]]]:
    """Drop, one at a time, the worst-determined term beyond the index pair until no term's σ is
    inflated by the points' geometry more than CONDITION_LIMIT times; return the terms and their solution."""
    while True:
        solved = _solve(names, points, latitude, altaz)
        if solved is not None:
            coefficients, inverse = solved
            amplification = [math.sqrt(max(inverse[i][i], 0.0) * len(points)) for i in range(len(names))]
            worst = max(range(2, len(names)), key=lambda i: amplification[i], default=None)
            if worst is None or amplification[worst] <= CONDITION_LIMIT:
                return names, coefficients, inverse
        else:
            worst = len(names) - 1
        names = names[:worst] + names[worst + 1:]


def fit(points: list[ModelPoint], latitude: float, altaz: bool) -> Fit:
    """The least-squares model of ``points`` with only the terms they determine (module docstring)."""
    names = candidate_terms(len(points), altaz)
    if not names:
        return Fit()
    names, coefficients, inverse = _determined(names, points, latitude, altaz)
    residuals = []
    for point in points:
        px, py = _predict(names, coefficients, point.mech, latitude, altaz)
        ex, ey = point.error()
        residuals.append((ex - px, ey - py))
    squares = sum(x * x + y * y for x, y in residuals)
    spare = 2 * len(points) - len(names)
    scatter = math.sqrt(squares / spare) if spare > 0 else None
    terms = tuple(Term(name, value, None if scatter is None else scatter * math.sqrt(max(inverse[i][i], 0.0)))
                  for i, (name, value) in enumerate(zip(names, coefficients, strict=True)))
    sides = {point.mech.side for point in points}
    return Fit(terms, tuple(residuals), math.sqrt(squares / len(points)), sides.pop() if len(sides) == 1 else 0)


def _predict(names: tuple[str, ...], coefficients: list[float], at: Place, latitude: float, altaz: bool
             ) -> tuple[float, float]:
    xs, ys = _row(names, at, latitude, altaz)
    return (sum(c * x for c, x in zip(coefficients, xs, strict=True)),
            sum(c * y for c, y in zip(coefficients, ys, strict=True)))


def offsets(model: Fit, at: Place, latitude: float, altaz: bool) -> tuple[float, float]:
    """(Δlon, Δlat) in degrees, mechanical minus true, the model predicts at a mechanical place."""
    if model.one_side and not altaz:
        at = Place(at.lon, at.lat, model.one_side)  # Fit.one_side: no flip the points cannot support
    d_lon = d_lat = 0.0
    for term in model.terms:
        p_lon, p_lat = partials(term.name, at, latitude, altaz)
        d_lon += term.value * p_lon
        d_lat += term.value * p_lat
    return d_lon / ARCSEC_PER_DEG, d_lat / ARCSEC_PER_DEG


def to_true(model: Fit, mech: Place, latitude: float, altaz: bool) -> Place:
    """Where the sky is for a mechanical place (forward)."""
    d_lon, d_lat = offsets(model, mech, latitude, altaz)
    return Place((mech.lon - d_lon) % 360.0, mech.lat - d_lat, mech.side)


def to_mechanical(model: Fit, true: Place, latitude: float, altaz: bool) -> Place:
    """The mechanical place whose sky is ``true`` (inverse: the forward model iterated to 0.001″)."""
    mech = true
    for _ in range(20):
        d_lon, d_lat = offsets(model, mech, latitude, altaz)
        nxt = Place((true.lon + d_lon) % 360.0, true.lat + d_lat, true.side)
        moved = abs((nxt.lon - mech.lon + 180.0) % 360.0 - 180.0) + abs(nxt.lat - mech.lat)
        mech = nxt
        if moved < 1e-3 / ARCSEC_PER_DEG:
            break
    return mech


def separation_deg(a: Place, b: Place) -> float:
    """Great-circle distance between two places of the same frame, in degrees."""
    return sky.angular_separation(a.lon / 15.0, a.lat, b.lon / 15.0, b.lat)


@dataclass(frozen=True)
class PointVerdict:
    """What adding a point did: ``accepted`` (and whether it ``replaced`` a near one) or why not."""

    accepted: bool
    replaced: bool = False
    message: str = ""


@dataclass
class PointingModel:
    """The points of one mount and their fit. Not thread-safe: its owner holds a lock.

    ``latitude`` and ``altaz`` are the site and mode the points were taken at: a model is a property
    of one set-up (its owner clears it when either changes, docs/pointing-model.md).
    """

    latitude: float = 0.0
    altaz: bool = False
    enabled: bool = True
    points: list[ModelPoint] = field(default_factory=list)
    solution: Fit = field(default_factory=Fit)
    last_refusal: str = ""
    #: The last refused point, if the last sync was refused: a second refused sync that agrees with it
    #: means the mount changed (a clutch slip, a re-homed axis, a new polar alignment), not a bad solve.
    refused: ModelPoint | None = None

    @property
    def active(self) -> Fit:
        """The fit in force: none while switched off."""
        return self.solution if self.enabled else Fit()

    def refit(self) -> None:
        self.solution = fit(self.points, self.latitude, self.altaz)

    def clear(self) -> None:
        self.points = []
        self.last_refusal = ""
        self.refused = None
        self.refit()

    def residual(self, point: ModelPoint) -> tuple[float, float]:
        """A point's measured error less the current model's prediction there (x, y arcseconds)."""
        px, py = _predict(tuple(t.name for t in self.solution.terms), [t.value for t in self.solution.terms],
                          point.mech, self.latitude, self.altaz)
        ex, ey = point.error()
        return ex - px, ey - py

    def miss_arcsec(self, point: ModelPoint) -> float:
        """How far the current model's prediction is from a point's measured error (arcseconds)."""
        return math.hypot(*self.residual(point))

    def outlier_limit(self, side: int) -> float | None:
        """The miss (arcseconds) beyond which a point on ``side`` is refused; None: too few points to judge."""
        same_side = sum(1 for p in self.points if p.mech.side == side)
        if len(self.points) < MIN_POINTS_FOR_OUTLIERS or same_side < OUTLIER_SIDE_POINTS:
            return None
        return max(OUTLIER_RMS * self.solution.rms, OUTLIER_FLOOR_ARCSEC)

    def add(self, point: ModelPoint) -> PointVerdict:
        """Add a sync's point: refused if it contradicts a model that has enough points to know,
        else it replaces any point within NEAR_DEG on its pier side and the model is refitted."""
        limit = self.outlier_limit(point.mech.side)
        miss = self.miss_arcsec(point)
        if limit is not None and miss > limit:
            if self._agrees_with_refused(point, limit):
                return self._restart(point)
            self.refused = point
            self.last_refusal = (
                f"sync point refused: it is {miss / 60.0:.1f}′ from where the pointing model of "
                f"{len(self.points)} points puts it (limit {limit / 60.0:.1f}′); a wrong plate solve or "
                "a mount moved on its clutches. The sync itself holds; a second sync that disagrees alike "
                "restarts the model, or clear it after a new polar alignment.")
            return PointVerdict(False, message=self.last_refusal)
        self.refused = None
        kept = [p for p in self.points
                if p.mech.side != point.mech.side or separation_deg(p.mech, point.mech) >= NEAR_DEG]
        replaced = len(kept) < len(self.points)
        self.points = [*kept, point][-MAX_POINTS:]
        self.last_refusal = ""
        self.refit()
        return PointVerdict(True, replaced, "replaced a point nearby" if replaced else "")

    def _agrees_with_refused(self, point: ModelPoint, limit: float) -> bool:
        """The last sync was refused too, and both miss the model alike along the axes (a slipped or
        re-homed axis shifts every place by one angle, whatever its declination): the mount changed."""
        if self.refused is None:
            return False

        def along_axes(p: ModelPoint) -> tuple[float, float]:
            x, y = self.residual(p)
            return x / max(0.1, math.cos(math.radians(p.mech.lat))), y

        (x1, y1), (x2, y2) = along_axes(self.refused), along_axes(point)
        return math.hypot(x1 - x2, y1 - y2) <= limit

    def _restart(self, point: ModelPoint) -> PointVerdict:
        """Start the model afresh from the two refused syncs that agree."""
        self.points = [self.refused, point] if self.refused is not None else [point]
        self.refused = None
        self.last_refusal = ("pointing model restarted: two syncs in a row disagreed with it alike (the mount "
                             "was moved, re-homed or polar-aligned again); it starts from those two")
        self.refit()
        return PointVerdict(True, message=self.last_refusal)

    # -- persistence --------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        return {"version": 1, "latitude": self.latitude, "altaz": self.altaz, "enabled": self.enabled,
                "points": [point_to_dict(p) for p in self.points]}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PointingModel:
        """A model from ``to_dict``'s shape; ValueError/KeyError/TypeError on anything else."""
        if data.get("version") != 1:
            raise ValueError("unknown pointing model file version")
        model = cls(float(data["latitude"]), bool(data["altaz"]), bool(data["enabled"]),
                    [point_from_dict(p) for p in data["points"]][-MAX_POINTS:])
        model.refit()
        return model


def _place_dict(place: Place) -> dict[str, float]:
    return {"lon": place.lon, "lat": place.lat, "side": place.side}


def point_to_dict(point: ModelPoint) -> dict[str, Any]:
    return {"mech": _place_dict(point.mech), "true": _place_dict(point.true), "time": point.time,
            "ra_h": point.ra_h, "dec_deg": point.dec_deg}


def _place_of(data: dict[str, Any]) -> Place:
    lon, lat, side = float(data["lon"]), float(data["lat"]), int(data["side"])
    if not (math.isfinite(lon) and -90.0 <= lat <= 90.0 and side in (-1, 1)):
        raise ValueError(f"bad place in the pointing model file: {data!r}")
    return Place(lon % 360.0, lat, side)


def point_from_dict(data: dict[str, Any]) -> ModelPoint:
    return ModelPoint(_place_of(data["mech"]), _place_of(data["true"]), str(data.get("time", "")),
                      float(data.get("ra_h", 0.0)), float(data.get("dec_deg", 0.0)))
