"""A mount that is not perfect: TPOINT's mechanical error terms and a repeatable scatter, as pure formulas.

The emulator is "reality": its axes believe they point at one place (what the mount reports) and the
tube truly points at another. This module says where, from the axes alone, so that a pointing model
(the server's, an estimator of these terms) can be measured against a known truth. It imports nothing
of the server's and nothing of the emulator's state: numbers in, numbers out.

**The terms and their signs are TPOINT's** (P. T. Wallace's TPOINT, "TPOINT: a telescope pointing
analysis system", §2.1 "The pointing terms"; the same conventions in Software Bisque's TheSkyX
manual, Appendix L "The Pointing Terms"): hour angle h positive west, Dec δ positive north, TPOINT's
azimuth A zero due south and 90° due east; a correction ΔX is the *corrected telescope position*
minus the *uncorrected one*, i.e. telescope = sky + Δ(position), with

    IH  Δh = -IH                       ID  Δδ = -ID
    CH  Δh = -CH sec δ                 NP  Δh = -NP tan δ
    MA  Δh = -MA cos h tan δ,          Δδ = +MA sin h
    ME  Δh = +ME sin h tan δ,          Δδ = +ME cos h
    TF  Δh = +TF cos φ sin h sec δ,    Δδ = +TF (cos φ cos h sin δ - sin φ cos δ)   (φ: latitude)

    IA  ΔA = -IA                       IE  ΔE = +IE
    CA  ΔA = -CA sec E                 NPAE ΔA = -NPAE tan E
    AN  ΔA = -AN sin A tan E,          ΔE = -AN cos A
    AW  ΔA = -AW cos A tan E,          ΔE = +AW sin A
    TF  ΔE = -TF cos E                 (alt-az)

**Which way they are applied.** TPOINT can run a model either way (its ``ADJUST`` option: from true
star positions to raw telescope positions, or from raw positions to true ones) with the *same
coefficient signs*. The emulator starts from what it has, its axes, and applies the terms in the
raw-to-true sense, evaluated at the axes' own (mechanical) position:

    sky = axes - Δ(axes)

so the offset from the mount's belief to the truth is exactly linear in the terms (what a
least-squares estimator wants); a model that applies them in the true-to-raw sense sees a difference
of the second order (a term squared times tan δ: about 10″ at Dec 60° for 20′ terms).

**Mechanical coordinates and pier sides.** TPOINT describes a German mount by its raw encoder position:
on the side with the Dec axis "through the pole" the declination is beyond ±90° (δ_m = ±180° - δ,
h_m = h + 12 h). Evaluated there, the terms that are properties of the machine rather than of the sky
(ID, CH, NP) change sign on the sky across a flip, as on a real mount, while the polar-axis terms (MA,
ME) and the flexure (TF) keep their sky meaning. South of the equator the same holds with the
mechanical declination near -90° (δ_m = -180° - δ on the outer side): ``outer`` here is the emulator's
``Hemisphere.outer`` (pierEast in the north, pierWest in the south).

Within 1° of a pole (or of the zenith in alt-az) the tan/sec factors are held at their 89° values:
TPOINT's formulas are singular there; the mount refuses syncs past Dec ±85° anyway.

**Noise** (``--pointing-noise``): an unmodelled scatter, repeatable, of a given RMS on the sky. It is a
smooth random field over the two axis angles (a seeded sum of sinusoids with 3 to 12 periods a turn),
so the same pointing gives the same scatter, nearby pointings give nearly the same (as flexure and
gear errors do), tracking does not make the star jump, and the two pier sides of one sky position
differ. Each on-sky component has RMS ``rms/√2`` over all axis angles, so the total is ``rms``.
"""

from __future__ import annotations

import math
import random
import re
from dataclasses import dataclass, field

__all__ = [
    "ALTAZ_TERMS",
    "EQUATORIAL_TERMS",
    "TERMS",
    "Imperfection",
    "NoiseField",
    "altaz_offset",
    "equatorial_offset",
    "parse_terms",
]

#: TPOINT's terms for an equatorial mount and for an alt-az one (TF is in both, with its own formula).
EQUATORIAL_TERMS = ("IH", "ID", "CH", "NP", "MA", "ME", "TF")
ALTAZ_TERMS = ("IA", "IE", "CA", "NPAE", "AN", "AW", "TF")
TERMS = tuple(dict.fromkeys(EQUATORIAL_TERMS + ALTAZ_TERMS))
#: The largest term accepted, arcminutes (10°): beyond it the first-order formulas mean nothing.
MAX_TERM_ARCMIN = 600.0
#: The largest scatter accepted, arcseconds (1°).
MAX_NOISE_ARCSEC = 3600.0
#: tan/sec are held at their value this far from a pole (or the zenith).
_POLE_GUARD_DEG = 1.0
_MIN_COS = math.sin(math.radians(_POLE_GUARD_DEG))
_TERM = re.compile(r"\s*([A-Za-z]+)\s*=\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*")


def parse_terms(text: str) -> dict[str, float]:
    """``"IH=20,ID=-8,MA=12"`` -> ``{"IH": 20.0, ...}`` (arcminutes); ``""`` or ``"none"`` -> ``{}``.

    ValueError (with what is wrong) for an unknown term, a repeated one, a value that is not a finite
    number or is larger than ``MAX_TERM_ARCMIN``: a typo must not silently leave the mount perfect.
    """
    terms: dict[str, float] = {}
    if text.strip().lower() in ("", "none"):
        return terms
    for item in text.split(","):
        match = _TERM.fullmatch(item)
        if match is None:
            raise ValueError(f"{item.strip()!r} is not NAME=ARCMINUTES (like IH=20)")
        name, value = match.group(1).upper(), float(match.group(2))
        if name not in TERMS:
            raise ValueError(f"unknown pointing term {name!r}; known: {', '.join(TERMS)}")
        if name in terms:
            raise ValueError(f"pointing term {name} given twice")
        if not abs(value) <= MAX_TERM_ARCMIN:
            raise ValueError(f"{name}={value:g} is beyond ±{MAX_TERM_ARCMIN:g} arcminutes")
        terms[name] = value
    return terms


def _tan_sec(angle_deg: float) -> tuple[float, float]:
    """(tan, sec) of an angle, held at their ``_POLE_GUARD_DEG`` values near ±90° (see the module)."""
    rad = math.radians(angle_deg)
    cos = math.cos(rad)
    if abs(cos) < _MIN_COS:
        cos = math.copysign(_MIN_COS, cos) if cos != 0.0 else _MIN_COS
    return math.sin(rad) / cos, 1.0 / cos


def _tpoint_equatorial(terms: dict[str, float], h_deg: float, d_deg: float, lat_deg: float) -> tuple[float, float]:
    """TPOINT's (Δh, Δδ) in arcminutes at the mechanical (h_m, δ_m) in degrees (the module's table)."""
    t = terms.get
    tan_d, sec_d = _tan_sec(d_deg)
    h, d, lat = math.radians(h_deg), math.radians(d_deg), math.radians(lat_deg)
    dh = -t("IH", 0.0) - t("CH", 0.0) * sec_d - t("NP", 0.0) * tan_d
    dh += (-t("MA", 0.0) * math.cos(h) + t("ME", 0.0) * math.sin(h)) * tan_d
    dh += t("TF", 0.0) * math.cos(lat) * math.sin(h) * sec_d
    dd = -t("ID", 0.0) + t("MA", 0.0) * math.sin(h) + t("ME", 0.0) * math.cos(h)
    dd += t("TF", 0.0) * (math.cos(lat) * math.cos(h) * math.sin(d) - math.sin(lat) * math.cos(d))
    return dh, dd


def equatorial_offset(terms: dict[str, float], ha_h: float, dec_deg: float, latitude_deg: float,
                      outer: bool) -> tuple[float, float]:
    """(ΔHA hours, ΔDec degrees) from where the axes of an equatorial mount believe they point (HA, Dec,
    the usual folded sky coordinates) to where the tube truly points: sky = (ha + ΔHA, dec + ΔDec).

    ``outer``: the Dec axis is through the pole (``Hemisphere.outer``: pierEast in the north, pierWest in
    the south), where TPOINT's mechanical declination is beyond ±90°. The pole of the site's hemisphere
    is the north one on the equator, as in ``Hemisphere.of``.
    """
    if outer:
        pole = 90.0 if latitude_deg >= 0.0 else -90.0
        dh, dd = _tpoint_equatorial(terms, ha_h * 15.0 + 180.0, 2.0 * pole - dec_deg, latitude_deg)
        dd = -dd  # δ = 2·pole - δ_m: the mechanical Dec runs the other way on the sky
    else:
        dh, dd = _tpoint_equatorial(terms, ha_h * 15.0, dec_deg, latitude_deg)
    # raw -> true: sky = axes - Δ(axes); Δh in arcminutes of hour angle (degrees/60), Δδ likewise.
    return -dh / 60.0 / 15.0, -dd / 60.0


def altaz_offset(terms: dict[str, float], az_deg: float, alt_deg: float) -> tuple[float, float]:
    """(Δazimuth, Δaltitude) in degrees from where the axes of an alt-az mount believe they point
    (azimuth from north through east, altitude; an altitude past 90° is the tube over the top) to where
    it truly points. TPOINT's azimuth is A = 180° - azimuth (zero south, 90° east)."""
    t = terms.get
    a = math.radians(180.0 - az_deg)
    tan_e, sec_e = _tan_sec(alt_deg)
    da = -t("IA", 0.0) - t("CA", 0.0) * sec_e - t("NPAE", 0.0) * tan_e
    da -= (t("AN", 0.0) * math.sin(a) + t("AW", 0.0) * math.cos(a)) * tan_e
    de = t("IE", 0.0) - t("AN", 0.0) * math.cos(a) + t("AW", 0.0) * math.sin(a)
    de -= t("TF", 0.0) * math.cos(math.radians(alt_deg))
    # raw -> true: A_sky = A - ΔA, so azimuth_sky = 180 - A_sky = azimuth + ΔA; E_sky = E - ΔE.
    return da / 60.0, -de / 60.0


@dataclass(frozen=True)
class NoiseField:
    """The repeatable scatter: a smooth function of the two axis angles (see the module), in arcseconds
    on the sky (east-west, north-south components)."""

    rms_arcsec: float
    seed: int = 0
    waves: int = 16
    _x: tuple[tuple[int, int, float], ...] = field(init=False, repr=False, compare=False)
    _y: tuple[tuple[int, int, float], ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rng = random.Random(self.seed)
        numbers = [(kp, ks) for kp in range(-12, 13) for ks in range(3, 13) if abs(kp) >= 3 or kp == 0]
        picked = rng.sample(numbers, 2 * self.waves)  # distinct waves: their squares add up exactly

        def component(chosen: list[tuple[int, int]]) -> tuple[tuple[int, int, float], ...]:
            return tuple((kp, ks, rng.uniform(0.0, 2.0 * math.pi)) for kp, ks in chosen)

        object.__setattr__(self, "_x", component(picked[: self.waves]))
        object.__setattr__(self, "_y", component(picked[self.waves:]))

    def at(self, p_deg: float, s_deg: float) -> tuple[float, float]:
        """(east-west, north-south) scatter in arcseconds for the axes at (p, s) degrees."""
        if self.rms_arcsec == 0.0:
            return 0.0, 0.0
        amplitude = self.rms_arcsec / math.sqrt(self.waves)  # per component: waves·a²/2 = rms²/2
        p, s = math.radians(p_deg), math.radians(s_deg)

        def value(waves: tuple[tuple[int, int, float], ...]) -> float:
            return amplitude * sum(math.sin(kp * p + ks * s + phase) for kp, ks, phase in waves)

        return value(self._x), value(self._y)


@dataclass(frozen=True)
class Imperfection:
    """One mount's errors: TPOINT terms (arcminutes) and a scatter. ``Imperfection()`` is a perfect mount."""

    terms: dict[str, float] = field(default_factory=dict)
    noise: NoiseField = field(default_factory=lambda: NoiseField(0.0))

    @staticmethod
    def of(terms: str = "", noise_arcsec: float = 0.0, seed: int = 0) -> Imperfection:
        """From the command line's forms; ValueError for bad terms or a scatter out of range."""
        return Imperfection(parse_terms(terms)).with_noise(noise_arcsec, seed)

    def with_terms(self, terms: str) -> Imperfection:
        """The same scatter, other terms (``parse_terms``'s form); ValueError for bad ones."""
        return Imperfection(parse_terms(terms), self.noise)

    def with_noise(self, noise_arcsec: float, seed: int) -> Imperfection:
        """The same terms, another scatter; ValueError for an RMS out of 0-``MAX_NOISE_ARCSEC``."""
        if not 0.0 <= noise_arcsec <= MAX_NOISE_ARCSEC:
            raise ValueError(f"pointing noise must be between 0 and {MAX_NOISE_ARCSEC:g} arcseconds")
        return Imperfection(dict(self.terms), NoiseField(float(noise_arcsec), int(seed)))

    @property
    def perfect(self) -> bool:
        return not any(self.terms.values()) and self.noise.rms_arcsec == 0.0

    def describe(self) -> dict[str, object]:
        """JSON-friendly: what the control port and the snapshot report."""
        return {"terms_arcmin": {k: v for k, v in self.terms.items() if v}, "noise_arcsec": self.noise.rms_arcsec,
                "seed": self.noise.seed}

    def equatorial_sky(self, p_deg: float, s_deg: float, ha_h: float, dec_deg: float, latitude_deg: float,
                       outer: bool) -> tuple[float, float]:
        """Where the tube truly points (HA hours, Dec degrees), for axes at (p, s) that read (ha, dec)."""
        dh, dd = equatorial_offset(self.terms, ha_h, dec_deg, latitude_deg, outer)
        lon, lat = _move((ha_h + dh) * 15.0, dec_deg + dd, self.noise.at(p_deg, s_deg))
        return (lon / 15.0 + 12.0) % 24.0 - 12.0, lat

    def altaz_sky(self, p_deg: float, s_deg: float) -> tuple[float, float]:
        """Where the tube of an alt-az mount with its axes at (p, s) truly points (altitude, azimuth degrees):
        p is the azimuth, s the altitude, past 90° when the tube is carried over the top."""
        da, de = altaz_offset(self.terms, p_deg, s_deg)
        az, alt = _move(p_deg + da, s_deg + de, self.noise.at(p_deg, s_deg))
        return alt, az % 360.0


def _move(lon_deg: float, lat_deg: float, offset_arcsec: tuple[float, float]) -> tuple[float, float]:
    """A (longitude-like, latitude-like) position in degrees moved by a small on-sky offset (along the
    longitude, along the latitude), folded back within ±90° of latitude (across a pole, or over the top)."""
    _, sec = _tan_sec(lat_deg)
    lon = lon_deg + offset_arcsec[0] / 3600.0 * sec
    lat = lat_deg + offset_arcsec[1] / 3600.0
    if lat > 90.0 or lat < -90.0:
        lat = math.copysign(180.0, lat) - lat
        lon += 180.0
    return lon, lat
