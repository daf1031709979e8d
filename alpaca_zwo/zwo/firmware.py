"""Firmware variants: how real ZWO firmware builds differ, as named, self-describing presets.

Real AM3/AM5/AM5N/AM7 firmware builds disagree on a handful of replies (field notes §5.6, §6): when
``:GU#`` shows ``H``, the order of the ``:GT#`` digits, what ``:Gps#``, ``:hP#`` and ``:Gh#``
answer, whether the documented compound ``:SMeq``/``:SMMC`` and custom ``:STR`` rates work, and
where ``:GMZA#`` counts azimuth from. A :class:`FirmwareVariant` is one such build: its name, the
model and version it reports and its quirks. The emulator behaves as the variant it is given; the
config file (``[emulator] preset``), the emulator's ``--preset`` option and the tests pick variants
by name from :data:`PRESETS`, so a quirk is described once, here.

No project imports: the config layer and the emulator both read this module.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass, fields
from typing import Any

__all__ = [
    "ACKS_HELD_WHILE_SLEWING",
    "ACK_WHILE_SLEWING",
    "DEFAULT_PRESET",
    "FEATURES_SINCE",
    "GH_REPLIES",
    "GPS_REPLIES",
    "GT_MAPPINGS",
    "HOME_FLAGS",
    "HOME_READINGS",
    "HP_REPLIES",
    "HP_WHILE_TRACKING",
    "JOG_RATES",
    "MEASURED_JOG_SPEEDS",
    "MODELS",
    "NS_MOVES",
    "PARKED_REFUSED",
    "PARK_REFUSALS",
    "PIER_LETTERS",
    "PRESETS",
    "STATUS_WORDS",
    "UNKNOWN_QUERIES",
    "FirmwareVariant",
    "has_feature",
    "preset",
    "version_tuple",
]

MODELS = ("AM3", "AM5", "AM5N", "AM7")
HOME_FLAGS = ("after_home", "never", "always_at_home")
GT_MAPPINGS = ("english", "chinese")
GPS_REPLIES = ("digits", "empty")
HP_REPLIES = (None, "1#")
GH_REPLIES = ("empty", "zero", "homed")
#: What ``:Gm#``'s E/W names (docs/southern.md): the pointing state of the axes at the site, the axes'
#: mechanical state as a northern mount names it (reversed south of the equator), or the side of the
#: pointing's hour angle whatever the axes (the two differ where the counterweight is up).
PIER_LETTERS = ("pointing_state", "mechanical", "hour_angle")
#: What ``:Mn#``/``:Mgn`` move (docs/southern.md): toward the sky's north on either pier side, or one
#: way of the Dec axis (north on pierEast, south on pierWest).
NS_MOVES = ("sky", "mechanical")
#: How a parked mount refuses motion: as the vendor documents let the emulator guess (a GOTO's
#: ``e4#``, a bare ``0`` to ``:Te#``, silence from the fire-and-forget commands), or as an AM5N on
#: 1.8.8 did on the wire: ``e14#`` to every command of :data:`PARKED_REFUSED` (docs/firmware-evidence.md).
PARK_REFUSALS = ("documents", "e14")
#: What ``:hP#`` does while tracking: parks (the documents), or is silently ignored (AM5N 1.8.8).
HP_WHILE_TRACKING = ("parks", "ignored")
#: The shape of ``:GU#``: the documents' letters (``P`` when parked) with a zero numeric tail, or
#: the 1.8.8 word: an ``M`` letter, no ``P``, parked or parking shows ``n`` alone, and the last digit
#: says the state (5 parked, 3 a manual move, 1 tracking, 0 otherwise).
STATUS_WORDS = ("documents", "1.8.8")
#: What a request the firmware does not know gets: nothing (the documents, field notes §2.9), or, as
#: 1.8.8 answered on the wire, a lone ``#`` for an unknown ``:G…#`` query (a known two-letter query
#: that no longer query extends is answered as itself whatever follows: ``:GCAL#`` is ``:GC#``),
#: with ``:GX…#`` and the queries forwarded to the second controller silent, and the 1.8.8 extras
#: ``:GAST#``, ``:GRr#``/``:GDr#`` and ``:GVD#`` answered (docs/firmware-evidence.md).
UNKNOWN_QUERIES = ("silent", "1.8.8")
#: What the mount reads at its home position (counterweight down, tube at the pole): the documents'
#: ``N`` and hour angle −6 h (in the north), or, as an AM5N on 1.8.8 read at home, the through-the-pole
#: side: ``E`` and hour angle +6 h, with the azimuth of the pole written ``360*00:00``.
HOME_READINGS = ("documents", "through_pole")
#: The :R0#…:R9# speeds: the documents' table, or as an AM5N on 1.8.8 was measured (S1): R3 1.9x,
#: R5 7.8x, R7 60x. R1 stays 0.5x: S1's table says 0.3x, but its own 10 s calibrations of the same
#: session moved 0.5x at R1 (docs/firmware-evidence.md, "Where the sources conflict").
JOG_RATES = ("documents", "measured")
MEASURED_JOG_SPEEDS: tuple[float, ...] = (0.25, 0.5, 1.0, 1.9, 4.0, 7.8, 20.0, 60.0, 720.0, 1440.0)
#: The request bodies a parked 1.8.8 mount answered ``e14#`` (``Mg`` stands for every pulse):
#: S1 (epim/astrodeck docs/hardware/zwo-am5-lx200-protocol.md) lists :MS# :Te# :TQ# :Mg*# :Ms# and
#: :hR# :hU# :hN# :hF# :hW# :hS# :hP# :I# :PO# :MP#; :Mn#/:Me#/:Mw# (the rest of the move class)
#: and :hC# (S2: "no motion after :hP#", reply not quoted) are the safe reading: refused alike.
PARKED_REFUSED = ("MS", "Te", "TQ", "Mg", "Mn", "Ms", "Me", "Mw", "hC", "hP", "hR", "hU", "hN", "hF",
                  "hW", "hS", "I", "PO", "MP")

#: What a busy mount does with an acknowledgement (:data:`ACKS_HELD_WHILE_SLEWING`) asked for while a
#: GOTO, home or park slew runs or brakes: answers at once (the documents), answers once the slew has
#: ended, or never answers. An AM5N on 1.8.8 left ``:Te#`` (and ``:Td#`` right after ``:Q#``) unanswered
#: for the whole 1.5 s its driver waited (epim/astrodeck server/astrodeck/devices/backends/zwo_am5.py,
#: the ``_link_error`` docstring; real-transcripts-1.8.8.md §2 item 8). Whether the byte came later
#: is not recorded, so both readings are switches; the 1.8.8 presets answer late, the case that tests
#: a client hardest (a stray byte arriving in the middle of later exchanges). The command itself takes
#: effect when it arrives, as the position reads that kept working during slews suggest.
ACK_WHILE_SLEWING = ("prompt", "late", "never")
#: The acknowledgements a slewing 1.8.8 mount was seen to hold back (the evidence names only these).
ACKS_HELD_WHILE_SLEWING = ("Te", "Td")

#: The firmware version from which a feature exists (field notes §5.6): the one table both the
#: driver (what it may send) and the emulator (what it answers) read.
FEATURES_SINCE: dict[str, tuple[int, ...]] = {
    "gat_error_codes": (1, 1, 1),  # :GAT# says why tracking stopped (INDIGO)
    "park": (1, 1, 9),  # mount park (INDI-v1.6)
    "meridian_settings": (1, 2, 4),  # :GTa#/:STa (INDIGO)
    "custom_park": (1, 3, 0),  # :Sp01# (INDI-v1.6)
    "home_flag": (1, 8, 1),  # 'H' in :GU# at the end of a home slew (INDI-v1.6)
}


def version_tuple(text: str) -> tuple[int, ...]:
    """``1.9.2`` -> (1, 9, 2); non-digits in a part are ignored, so ``1.2.4b`` compares as 1.2.4."""
    return tuple(int("".join(ch for ch in part if ch.isdigit()) or 0) for part in text.split("."))


def has_feature(version: str, feature: str) -> bool:
    """Whether firmware ``version`` has ``feature`` (a key of :data:`FEATURES_SINCE`)."""
    return version_tuple(version) >= FEATURES_SINCE[feature]


#: The switches that are quirks (everything but the identity fields).
_IDENTITY = ("name", "model", "version", "compile_time", "build_date", "description")


@dataclass
class FirmwareVariant:
    """Switches for the behaviours that differ between real firmware builds (field notes §5.6, §6).

    Mutable on purpose: a test may flip one switch on a running model to see how a client copes.
    """

    model: str = "AM5"  # :GVP#
    version: str = "1.9.2"  # :GV#
    compile_time: str = "10:24:36"  # :GVT# (listed in V1.1, unconfirmed on hardware)
    home_flag: str = "after_home"  # 'H' in :GU#: after_home | never | always_at_home
    gt_mapping: str = "english"  # :GT# digits: english 1 solar 2 lunar | chinese 1 lunar 2 solar
    gps_reply: str = "digits"  # :Gps#: digits 0/1/2 | empty '#'
    hp_reply: str | None = None  # :hP#: None (no reply, v1.8+) | "1#" (1#/0#, seen by PYAM5)
    gh_reply: str = "empty"  # :Gh#: empty '#' | zero '0#' | homed '1#' after a home, else '0#'
    compound_goto_sync: bool = False  # False: :SMeq/:SMMC answer e2# as on hardware
    custom_tracking: bool = False  # False: :STR gets no reply (absent on real firmware)
    gmza_south_azimuth: bool = False  # True: :GMZA# azimuth from south (AM5N showed 180 at home)
    #: The open readings of the evidence (docs/meridian.md, docs/southern.md): where a GOTO's side
    #: flips (False: past the track-past limit; True: at the meridian itself, a negative limit still
    #: moving the line before it), what :Gm# names, what :Mn#/:Mgn move.
    goto_flip_at_meridian: bool = False
    pier_letter: str = "pointing_state"  # pointing_state | mechanical | hour_angle
    ns_moves: str = "sky"  # sky | mechanical
    #: What a power cycle keeps of the site: False, the site stored at the factory (or the emulator's
    #: start) comes back, as an AM5N on 1.6.3 read Suzhou at power-up; True, the last :St/:Sg are
    #: kept, as the NVS keys "latitude"/"longitude" of the 1.8.8 firmware suggest (docs/southern.md).
    site_in_flash: bool = False
    #: The firmware's own park as real 1.8.8 mounts showed it (docs/firmware-evidence.md): how a
    #: parked mount refuses motion, whether :hP# parks while tracking, what :GU# looks like.
    park_refusal: str = "documents"  # documents | e14
    hp_while_tracking: str = "parks"  # parks | ignored
    status_word: str = "documents"  # documents | 1.8.8
    unknown_query: str = "silent"  # silent | 1.8.8
    home_reading: str = "documents"  # documents | through_pole
    jog_rates: str = "documents"  # documents | measured
    #: Where :hP# goes: the factory park (OTA horizontal) or, as an AM5N on 1.8.8 did ("`:hP#` park
    #: slews home from anywhere", Dec read +90 while parked), the home position.
    park_at_home: bool = False
    build_date: str = "Jan 25 2026"  # :GVD# (answered where unknown_query is 1.8.8)
    ack_while_slewing: str = "prompt"  # prompt | late | never (ACK_WHILE_SLEWING)
    name: str = "custom"  # the preset this came from ("custom" when built by hand)
    description: str = ""  # where this build's behaviour was seen

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Reject a misspelt switch value early instead of silently acting as the default."""
        choices = {
            "home_flag": HOME_FLAGS,
            "gt_mapping": GT_MAPPINGS,
            "gps_reply": GPS_REPLIES,
            "hp_reply": HP_REPLIES,
            "gh_reply": GH_REPLIES,
            "pier_letter": PIER_LETTERS,
            "ns_moves": NS_MOVES,
            "park_refusal": PARK_REFUSALS,
            "hp_while_tracking": HP_WHILE_TRACKING,
            "status_word": STATUS_WORDS,
            "unknown_query": UNKNOWN_QUERIES,
            "home_reading": HOME_READINGS,
            "jog_rates": JOG_RATES,
            "ack_while_slewing": ACK_WHILE_SLEWING,
        }
        for name, allowed in choices.items():
            if getattr(self, name) not in allowed:
                raise ValueError(f"FirmwareVariant.{name} must be one of {allowed}, not {getattr(self, name)!r}")
        if not re.fullmatch(r"AM\d{1,2}[A-Z]{0,2}", self.model):  # AM5N, or a suffix still to come (AM5X)
            raise ValueError(f"not a ZWO mount model: {self.model!r}")

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def quirks(self) -> dict[str, Any]:
        """The switches where this build differs from the default variant (what makes it special)."""
        baseline = FirmwareVariant()
        return {f.name: getattr(self, f.name) for f in fields(self)
                if f.name not in _IDENTITY and getattr(self, f.name) != getattr(baseline, f.name)}

    def describe(self) -> str:
        """One line for logs and ``--list-presets``: name, model, version and quirks."""
        quirks = ", ".join(f"{k}={v}" for k, v in self.quirks().items()) or "no quirks"
        return f"{self.name}: {self.model} firmware {self.version} ({quirks})"


def _preset(name: str, description: str, **switches: Any) -> FirmwareVariant:
    return FirmwareVariant(name=name, description=description, **switches)


#: What the 1.8.8 transcripts show (docs/firmware-evidence.md): :hP# answers nothing (S1's byte-level
#: capture; S2's unverified "1#/0#" stays a switch, ``hp_reply``), the firmware's own park.
_REAL_1_8_8: dict[str, Any] = {"hp_reply": None, "park_refusal": "e14", "hp_while_tracking": "ignored",
                               "status_word": "1.8.8", "unknown_query": "1.8.8", "home_reading": "through_pole",
                               "jog_rates": "measured", "park_at_home": True, "gh_reply": "zero",
                               "ack_while_slewing": "late"}

#: Named builds, the first the default. Each quirk cites where it was seen (field notes §0 keys).
PRESETS: dict[str, FirmwareVariant] = {
    variant.name: variant
    for variant in (
        _preset("am5-1.9.2", "current AM5 firmware: H after a home, :hP# silent, :Gh# empty"),
        _preset("am5n-1.6.3", "AM5N on 1.6.3: no H even at home, :GMZA# azimuth from south (AM5N notes)",
                model="AM5N", version="1.6.3", home_flag="never", gmza_south_azimuth=True),
        _preset("am5-1.8.8", "AM5 on 1.8.8 as recorded on the wire (docs/firmware-evidence.md)",
                version="1.8.8", compile_time="14:01:29", **_REAL_1_8_8),
        _preset("am5n-1.8.8", "AM5N on 1.8.8 as recorded on the wire (docs/firmware-evidence.md)",
                model="AM5N", version="1.8.8", compile_time="14:01:29", **_REAL_1_8_8),
        _preset("am5-x2", "builds seen by X2: H at power-up, :Gps# empty, :Gh# 0 even after homing",
                home_flag="always_at_home", gps_reply="empty", gh_reply="zero"),
        _preset("am3-1.6.3", "AM3 reporting 1.6.3", model="AM3", version="1.6.3"),
        _preset("am7-2.0.0", "AM7 reporting 2.0.0", model="AM7", version="2.0.0"),
    )
}
DEFAULT_PRESET = next(iter(PRESETS))


def preset(name: str = DEFAULT_PRESET, **overrides: Any) -> FirmwareVariant:
    """A fresh copy of preset ``name`` with some switches changed (``model=``, ``version=``, ...)."""
    try:
        base = PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown firmware preset {name!r}; presets: {', '.join(PRESETS)}") from None
    variant = dataclasses.replace(base, **overrides)
    if overrides and any(getattr(variant, k) != getattr(base, k) for k in overrides if k not in _IDENTITY):
        variant.name = f"{base.name}+custom"
    return variant
