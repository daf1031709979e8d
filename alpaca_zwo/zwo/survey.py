"""An owner's survey: ask a mount only questions that move nothing and change nothing, record every
exchange with its timing, and say which firmware variant switches the answers settle (issue 39 item 5).

Real firmware builds answer differently (``firmware.py``; ``docs/firmware-evidence.md``), and the project
learns how only from owners' mounts. The survey is what an owner can run and attach to a report:

- :data:`SURVEY_COMMANDS` is the one fixed list of what is ever sent. Each is a query of the command table
  (``protocol.COMMANDS``) that answers text and has no effect (``Effect.NONE``): no motion, no setting, no
  clock or site change. Identifier queries (MAC address, serial number, Bluetooth name) are not in it at all.
- :func:`run_survey` sends them one by one through a ``send`` callable (the server's own :class:`~.link.Link`
  ``exchange``: serialised with the poller when the server runs) and keeps each exchange's bytes and time.
- :data:`SWITCH_PROBES` pairs every :class:`~.firmware.FirmwareVariant` switch with the commands whose
  replies decide it and a classifier of those replies, or says why no read-only question can (it needs
  motion, a power cycle or another state): the verdict of every switch comes from that one table.
- :class:`SurveyReport` renders the text file, with the site-revealing digits left out (:data:`PRIVATE`).

No project imports beyond this package: the CLI (before the server connects) and the page (through the
facade, while it runs) both build on it.
"""

from __future__ import annotations

import platform
import re
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from datetime import datetime, timezone
from typing import Any

from .._exceptions import LinkError, LinkTimeout, ProtocolError
from . import firmware, protocol
from .wire_values import parse_dms, parse_hms

__all__ = [
    "PRIVATE",
    "SURVEY_COMMANDS",
    "SWITCH_PROBES",
    "Exchange",
    "SurveyContext",
    "SurveyReport",
    "SwitchProbe",
    "SwitchVerdict",
    "judge_all",
    "redact",
    "run_survey",
]

#: Everything the survey ever sends, in order (docs/survey.md lists the same, with why each is safe).
#: Identity first, so a report names the mount even when it ends early.
SURVEY_COMMANDS: tuple[str, ...] = (
    "GVP", "GV", "GVT",  # model, firmware version, compile time
    "GU", "GAT", "GT", "Gps", "Gh", "Gm",  # status word, tracking, rate digit, park, homed, pier letter
    "GR", "GD", "GS", "GZ", "GMZA", "GA", "Gr", "Gd",  # position, sidereal time, azimuth twice, target
    "GC", "GL", "GG", "GH", "Gt", "Gg",  # date, time, zone, daylight saving, site
    "GTa", "GLC", "GLH", "GLL", "GRl", "Ggr", "GBu",  # stored settings (meridian, limits, speed, guide, buzzer)
)

#: Replies that, with the report's time stamp, give away where the mount stands: the site itself, and the
#: sidereal time and the position (at home RA is LST - 6 h, and altitude is the latitude). The file keeps
#: their sign, first field (whole degrees or hours) and shape, and writes every later digit as ``x``.
PRIVATE: frozenset[str] = frozenset({"Gt", "Gg", "GS", "GR", "Gr", "GA", "GZ", "GMZA"})


def redact(reply: str) -> str:
    """``+37*07:51#`` -> ``+37*xx:xx#``: each ``&``-separated field keeps what precedes its first separator."""
    return "&".join(re.sub(r"^([^*:\xdf\xb0']*[*:\xdf\xb0'])(.*)$",
                           lambda m: m.group(1) + re.sub(r"\d", "x", m.group(2)), part)
                    for part in reply.split("&"))


# --------------------------------------------------------------------------------------------
# One exchange and its record
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Exchange:
    """One question and what came back: ``reply`` is the raw text (``#`` included), None when nothing
    complete came (``note`` says what: silence, a garbled reply, a lost link)."""

    code: str
    sent: str
    reply: str | None
    started_ms: float  # since the survey began
    took_ms: float
    note: str = ""

    def shown_reply(self) -> str:
        """The reply as the file writes it: quoted, private digits as ``x``, anything unprintable escaped."""
        private = self.code in PRIVATE
        if self.reply is None:  # the link's words may quote what came: as private as a reply
            return f"(nothing: {redact(self.note) if private else self.note})"
        text = redact(self.reply) if private else self.reply
        quoted = "".join(ch if " " <= ch <= "~" else f"\\x{ord(ch):02x}" for ch in text)
        extra = "  (a lone '#': the empty answer)" if self.reply == "#" else ""
        return f'"{quoted}" ({len(self.reply)} B){extra}'


Send = Callable[[protocol.Request], str]


def _ask(send: Send, code: str, began: float) -> Exchange:
    """Send one survey question; silence and garbled replies are recorded, never raised."""
    request = protocol.query(code)
    started = time.monotonic()
    reply: str | None = None
    note = ""
    try:
        reply = send(request)
    except LinkTimeout as exc:
        note = f"silence: {exc}"
    except ProtocolError as exc:  # implausible, unterminated or several replies in one (AmbiguousReply too)
        note = f"not one reply: {exc}"
    done = time.monotonic()
    return Exchange(code, request.text, reply, (started - began) * 1000.0, (done - started) * 1000.0, note)


# --------------------------------------------------------------------------------------------
# Switches and the replies that decide them
# --------------------------------------------------------------------------------------------

Readings = Mapping[str, str | None]
#: The switch values the replies allow (a subset of the switch's choices), or None: these replies say nothing.
Classifier = Callable[[Readings], "frozenset[Any] | None"]


@dataclass(frozen=True)
class SwitchProbe:
    """One variant switch: the survey commands whose replies decide it, and how (``classify``).

    ``needs`` says, in words, what would settle it when the replies cannot: the motion, power cycle or
    state no read-only question provides. A probe with no commands is always open for that reason.
    """

    switch: str
    commands: tuple[str, ...]
    classify: Classifier | None
    needs: str


def _body(readings: Readings, code: str) -> str | None:
    reply = readings.get(code)
    return reply[:-1] if reply is not None and reply.endswith("#") else None


def _identity(code: str) -> Classifier:
    def classify(readings: Readings) -> frozenset[Any] | None:
        body = _body(readings, code)
        return frozenset({body}) if body else None

    return classify


def _park_status_reply(readings: Readings) -> frozenset[Any] | None:
    body = _body(readings, "Gps")
    if body is None:
        return None
    return frozenset({"empty"} if body == "" else {"digits"} if body.isdigit() else set())


def _homed_reply(readings: Readings) -> frozenset[Any] | None:
    body = _body(readings, "Gh")
    if body is None:
        return None
    # '0' is also what a build that reports homing says before its first home.
    return frozenset({"": {"empty"}, "0": {"zero", "homed"}, "1": {"homed"}}.get(body, set()))


def _azimuth(text: str | None) -> float | None:
    try:
        return None if text is None else parse_dms(text.split("&")[0])
    except (ProtocolError, ValueError):
        return None


def _south_azimuth(readings: Readings) -> frozenset[Any] | None:
    """:GMZA#'s azimuth against :GZ#'s, read a moment apart: the same (north-based) or 180 degrees off.
    Not while the status word shows a slew (no 'N'): the two readings would differ by the motion."""
    plain, paired, status = _azimuth(_body(readings, "GZ")), _azimuth(_body(readings, "GMZA")), _status(readings)
    if plain is None or paired is None or status is None or "N" not in status[0]:
        return None
    apart = abs((paired - plain + 180.0) % 360.0 - 180.0)
    if apart < 1.0:
        return frozenset({False})
    return frozenset({True}) if apart > 179.0 else frozenset()


def _status(readings: Readings) -> tuple[str, str] | None:
    body = _body(readings, "GU")
    match = re.fullmatch(r"([A-Za-z]*)(\d*)", body) if body is not None else None
    return (match.group(1), match.group(2)) if match else None


def _home_letter(readings: Readings) -> frozenset[Any] | None:
    """'H' shows only at home, so one showing rules out the build that never shows it. No 'H' proves nothing:
    the position replies (whole seconds) cannot tell the exact home from a few arcseconds off it, where
    no build shows 'H', and the survey cannot know whether the mount was homed since its power-up."""
    status = _status(readings)
    if status is None or "H" not in status[0]:
        return None
    return frozenset({"after_home", "always_at_home"})


def _status_word(readings: Readings) -> frozenset[Any] | None:
    """The 1.8.8 word carries an ``M`` and a live numeric tail; the documents' word neither."""
    status = _status(readings)
    if status is None:
        return None
    letters, digits = status
    real = "M" in letters or digits.strip("0") != ""
    return frozenset({"1.8.8" if real else "documents"})


def _hour_angle(readings: Readings) -> float | None:
    """LST minus RA, hours in [-12, 12), from the :GS# and :GR# replies."""
    lst, ra = _body(readings, "GS"), _body(readings, "GR")
    try:
        return None if lst is None or ra is None else (parse_hms(lst) - parse_hms(ra) + 12.0) % 24.0 - 12.0
    except (ProtocolError, ValueError):
        return None


def _home_reading(readings: Readings) -> frozenset[Any] | None:
    """At rest at home (Dec at the pole, hour angle ±6 h): ``N`` is the documents' reading, ``E``/``W``
    the through-the-pole side real 1.8.8 mounts read (docs/firmware-evidence.md). Elsewhere: open."""
    letter, dec, status, ha = _body(readings, "Gm"), _body(readings, "GD"), _status(readings), _hour_angle(readings)
    if letter is None or dec not in ("+90*00:00", "-90*00:00") or status is None or "N" not in status[0]:
        return None
    if ha is None or abs(abs(ha) - 6.0) > 1.0 / 60.0:
        return None
    return frozenset({"documents"} if letter == "N" else {"through_pole"} if letter in ("E", "W") else set())


#: Every switch with what decides it. A FirmwareVariant field without a row here fails
#: tests/zwo/test_survey.py: a new switch must say how an owner's mount settles it, or why it cannot.
#: Rows for switches this build's FirmwareVariant lacks (other branches add them) are ignored.
SWITCH_PROBES: tuple[SwitchProbe, ...] = (
    SwitchProbe("model", ("GVP",), _identity("GVP"), ""),
    SwitchProbe("version", ("GV",), _identity("GV"), ""),
    SwitchProbe("compile_time", ("GVT",), _identity("GVT"), ""),
    SwitchProbe("gps_reply", ("Gps",), _park_status_reply, ""),
    SwitchProbe("gh_reply", ("Gh",), _homed_reply,
                "a home slew (:hC#), which moves the mount: before one, '0#' fits both 'zero' and 'homed'"),
    SwitchProbe("gmza_south_azimuth", ("GU", "GZ", "GMZA"), _south_azimuth,
                "both azimuth readings, taken while the mount is not slewing"),
    SwitchProbe("home_flag", ("GU",), _home_letter,
                "a home slew (:hC#), which moves the mount, to see whether 'H' shows after it and after a power "
                "cycle; an 'H' already showing rules out only 'never'"),
    SwitchProbe("status_word", ("GU",), _status_word, "a status word"),
    SwitchProbe("gt_mapping", ("GT",), None,
                "a known solar or lunar rate selected (:TS#/:TL#), which changes the tracking; sidereal reads "
                "'0' on every build"),
    SwitchProbe("hp_reply", (), None, "sending :hP#, which parks the mount"),
    SwitchProbe("hp_while_tracking", (), None, "sending :hP# while tracking, which may park the mount"),
    SwitchProbe("park_refusal", (), None, "a parked mount sent a motion command, which moves an unparked one"),
    SwitchProbe("compound_goto_sync", (), None, "sending :SMeq# or :SMMC#, which slew or sync the mount"),
    SwitchProbe("custom_tracking", (), None, "sending :STR, which sets the tracking rate"),
    SwitchProbe("goto_flip_at_meridian", (), None, "a GOTO across the meridian, which moves the mount"),
    SwitchProbe("pier_letter", ("Gm",), None,
                "the mount away from home with the counterweight up, or at a southern site, and its axis "
                "angles, which no read-only command gives; at home every build's letter is the same"),
    SwitchProbe("ns_moves", (), None, "a move north (:Mn#) on each pier side, which moves the mount"),
    SwitchProbe("site_in_flash", (), None, "a power cycle after setting the site (:St/:Sg), which changes it"),
    SwitchProbe("home_reading", ("GU", "Gm", "GD", "GS", "GR"), _home_reading,
                "the mount at rest at its home position (Dec at the pole, hour angle 6 h)"),
    SwitchProbe("unknown_query", (), None, "an unknown query (:GW#), which the survey's fixed list leaves out"),
    SwitchProbe("build_date", (), None, ":GVD#, which only some builds know (not in the fixed list)"),
    SwitchProbe("jog_rates", (), None, "a timed move at :R3#/:R5#, which moves the mount"),
    SwitchProbe("park_at_home", (), None, "sending :hP#, which parks the mount"),
    SwitchProbe("ack_while_slewing", (), None, ":Te# sent during a GOTO, which moves the mount"),
)


#: The constant in ``firmware`` that lists each switch's values (the last three: the 1.8.8 park switches,
#: read when this build has them).
_CHOICES = {"home_flag": "HOME_FLAGS", "gt_mapping": "GT_MAPPINGS", "gps_reply": "GPS_REPLIES",
            "hp_reply": "HP_REPLIES", "gh_reply": "GH_REPLIES", "pier_letter": "PIER_LETTERS",
            "ns_moves": "NS_MOVES", "park_refusal": "PARK_REFUSALS", "hp_while_tracking": "HP_WHILE_TRACKING",
            "status_word": "STATUS_WORDS", "unknown_query": "UNKNOWN_QUERIES", "home_reading": "HOME_READINGS",
            "jog_rates": "JOG_RATES", "ack_while_slewing": "ACK_WHILE_SLEWING"}


def _choices(switch: str) -> frozenset[Any] | None:
    """The values a switch may take, when it has a fixed set (None for the identity fields)."""
    listed = getattr(firmware, _CHOICES.get(switch, ""), None)
    if listed is not None:
        return frozenset(listed)
    default = getattr(firmware.FirmwareVariant(), switch)
    return frozenset({False, True}) if isinstance(default, bool) else None


@dataclass(frozen=True)
class SwitchVerdict:
    """What the replies say of one switch: ``values`` it may still have (empty: none fits), or open."""

    switch: str
    state: str  # "settled" | "narrowed" | "open" | "unexpected"
    values: tuple[Any, ...]
    why: str

    def line(self) -> str:
        shown = " or ".join(repr(v) if isinstance(v, str) else str(v) for v in self.values)
        if self.state == "settled":
            return f"{self.switch} = {shown} ({self.why})"
        if self.state == "narrowed":
            return f"{self.switch}: {shown}; to settle it needs {self.why}"
        if self.state == "unexpected":
            return f"{self.switch}: the replies fit no known value ({self.why}): please attach this report to an issue"
        return f"{self.switch}: open; needs {self.why}"


def _judge(probe: SwitchProbe, readings: Readings) -> SwitchVerdict:
    allowed = _choices(probe.switch)
    values = probe.classify(readings) if probe.classify is not None else None
    asked = ", ".join(f":{code}#" for code in probe.commands)
    if values is None:
        return SwitchVerdict(probe.switch, "open", (), probe.needs or f"an answer to {asked}")
    if allowed is not None:
        values = values & allowed
    ordered = tuple(sorted(values, key=str))
    if not values:
        return SwitchVerdict(probe.switch, "unexpected", (), f"from {asked}")
    if len(values) == 1:
        return SwitchVerdict(probe.switch, "settled", ordered, f"from {asked}")
    return SwitchVerdict(probe.switch, "narrowed", ordered, probe.needs)


def judge_all(readings: Readings) -> list[SwitchVerdict]:
    """One verdict per switch of this build's FirmwareVariant (identity fields and quirks), in table order."""
    present = {f.name for f in fields(firmware.FirmwareVariant)}
    return [_judge(probe, readings) for probe in SWITCH_PROBES if probe.switch in present]


# --------------------------------------------------------------------------------------------
# The survey and its report
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SurveyContext:
    """What the report's header says besides the mount's answers: no host name, user or port path."""

    version: str  # alpaca-zwo's
    when_utc: str  # ISO 8601
    computer: str  # OS, release, machine, Python
    connection: str  # "serial port", "TCP (WiFi or a bridge)", "the built-in emulator, preset am5-1.9.2"

    @classmethod
    def here(cls, version: str, url: str, preset: str = "") -> SurveyContext:
        """This computer now, and the kind of connection ``url`` is (never the URL: a serial port's
        name may hold the adapter's serial number, a TCP address the owner's network)."""
        if not url:
            connection = f"the built-in emulator, preset {preset or '?'}"
        elif url.startswith(("socket://", "rfc2217://")):
            connection = "TCP (the mount's WiFi, or a bridge)"
        else:
            connection = "serial port (USB)"
        computer = (f"{platform.system()} {platform.release()} {platform.machine()}, "
                    f"Python {platform.python_version()}")
        when = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
        return cls(version, when, computer, connection)


@dataclass
class SurveyReport:
    """Every exchange of one survey, and what they settle."""

    context: SurveyContext
    exchanges: list[Exchange] = field(default_factory=list)
    stopped: str = ""  # why the survey ended early ('' when every command was asked)

    def file_name(self) -> str:
        """``alpaca-zwo-survey-20261202T093000Z.txt``: the survey's UTC time, no ':' (Windows refuses it)."""
        return f"alpaca-zwo-survey-{self.context.when_utc.replace('-', '').replace(':', '')}.txt"

    def readings(self) -> dict[str, str | None]:
        return {e.code: e.reply for e in self.exchanges}

    def verdicts(self) -> list[SwitchVerdict]:
        return judge_all(self.readings())

    def identity(self) -> str:
        readings = self.readings()
        model, version, built = (_body(readings, code) for code in ("GVP", "GV", "GVT"))
        return f"{model or '?'} firmware {version or '?'} (compiled {built or '?'})"

    def text(self) -> str:
        """The file an owner attaches: header, every exchange with its timing, the verdict."""
        c = self.context
        lines = [
            "alpaca-zwo mount survey (read-only; docs/survey.md)",
            f"alpaca-zwo version: {c.version}",
            f"survey time (UTC): {c.when_utc}",
            f"computer: {c.computer}",
            f"connection: {c.connection}",
            f"mount: {self.identity()}",
            "left out: MAC address, serial number, Bluetooth and WiFi names are never asked; in the replies of "
            + ", ".join(f":{code}#" for code in sorted(PRIVATE)) + " every digit after the first field is "
            "written x (the site and the sidereal time would show where the mount stands)",
            "",
            f"exchanges ({len(self.exchanges)} of {len(SURVEY_COMMANDS)}); start and duration in milliseconds:",
        ]
        lines += [f"{e.started_ms:9.1f} {e.took_ms:8.1f}  {e.sent:<8} -> {e.shown_reply()}" for e in self.exchanges]
        if self.stopped:
            lines.append(f"survey stopped early: {self.stopped}")
        lines += ["", "variant switches (alpaca_zwo/zwo/firmware.py):"]
        lines += [f"  {v.line()}" for v in self.verdicts()]
        return "\n".join(lines) + "\n"


#: This many questions in a row without a reply: the mount has stopped answering (a known query on the
#: list is silent alone, as :GTa# before 1.2.4), so the rest would only add a timeout each.
MUTE_AFTER = 3


def run_survey(send: Send, context: SurveyContext, commands: Sequence[str] = SURVEY_COMMANDS) -> SurveyReport:
    """Ask every command of ``commands`` (a subset of :data:`SURVEY_COMMANDS`) through ``send``, in order.

    A lost link, or a mount silent :data:`MUTE_AFTER` times in a row, ends the survey (what was asked is
    kept, ``stopped`` says why); a single silence or garbled reply is recorded and the survey goes on,
    since a silent query is itself an answer worth reporting.
    """
    unknown = [code for code in commands if code not in SURVEY_COMMANDS]
    if unknown:
        raise ValueError(f"not survey commands: {unknown}")
    report = SurveyReport(context)
    began = time.monotonic()
    for code in commands:
        try:
            report.exchanges.append(_ask(send, code, began))
        except LinkError as exc:
            report.stopped = f"the link to the mount failed at :{code}#: {exc}"
            break
        recent = report.exchanges[-MUTE_AFTER:]
        if len(recent) == MUTE_AFTER and all(e.reply is None for e in recent):
            report.stopped = f"the mount stopped answering ({MUTE_AFTER} questions in a row without a reply)"
            break
    return report
