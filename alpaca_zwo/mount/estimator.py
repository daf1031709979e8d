"""Full-precision RA/Dec between the mount's coarse readings.

The mount reports RA to one second of time (15″ at the equator) and Dec to one arcsecond. Clients
check much finer than that (ConformU's 1″ pulse-guide test, NINA's 1″ sync check), so the
estimator carries a full-precision position forward from what the server itself commanded (sync
and GOTO coordinates, pulses, tracking and offset rates) for as long as the mount's readings agree
with it, and falls back to the readings the moment they do not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..zwo import wire_values


def wire_position(ra: float, dec: float) -> tuple[float, float]:
    """(RA, Dec) as the mount receives them in ``:Sr``/``:Sd``: whole seconds of RA, whole arcseconds."""
    return (wire_values.parse_hms(wire_values.format_hms(ra)),
            wire_values.parse_dms(wire_values.format_dms(max(-90.0, min(90.0, dec)))))


def _wrap12(hours: float) -> float:
    return (hours + 12.0) % 24.0 - 12.0


@dataclass(frozen=True)
class SyncRemainder:
    """What a sync's wire could not carry: the synced position minus the whole seconds and arcseconds
    the mount was synced to (at most 0.5 s of RA, 0.5″ of Dec).

    The mount makes its reading equal the wire values at the sync, so the client's frame (the
    *sky* frame) is the mount's frame plus this remainder: readings add it, GOTO targets lose it
    before they are rounded. Without it a sync to a solved position is off by up to 7.5″·cos(Dec)
    after the next GOTO (R23 in shared/alpaca/clients.md). It lives as long as the mount's own
    sync: until the next sync, ``:NSC#``, or a mount restart (which also is when a mode change
    takes effect); the mount keeps its alignment across home and park, and so does this.
    """

    ra: float = 0.0  # hours
    dec: float = 0.0  # degrees

    @classmethod
    def of_sync(cls, ra: float, dec: float) -> SyncRemainder:
        wire_ra, wire_dec = wire_position(ra, dec)
        return cls(_wrap12(ra - wire_ra), dec - wire_dec)

    def to_sky(self, ra: float, dec: float) -> tuple[float, float]:
        """A mount-frame position in the synced (client) frame."""
        return (ra + self.ra) % 24.0, max(-90.0, min(90.0, dec + self.dec))

    def to_mount(self, ra: float, dec: float) -> tuple[float, float]:
        """A client's position as the mount must be given it."""
        return (ra - self.ra) % 24.0, max(-90.0, min(90.0, dec - self.dec))


@dataclass
class PositionEstimator:
    """Full-precision RA/Dec carried forward between coarse mount readings.

    The estimate is an anchor plus linear motion: RA drifts at ``ra_rate`` (hours/s: zero while
    tracking at sidereal, the sidereal rate when not tracking) and each pulse adds its known
    displacement. A reading that disagrees with the estimate by more than the mount's own
    resolution (plus a margin) re-anchors to the reading, so the estimate can refine the mount's
    numbers but never contradict them.
    """

    ra_tolerance_h: float = 1.2 / 3600.0  # the mount prints whole seconds of RA
    dec_tolerance_deg: float = 1.2 / 3600.0  # and whole arcseconds of Dec
    anchor_ra: float | None = None
    anchor_dec: float | None = None
    anchor_time: float = 0.0
    ra_rate: float = 0.0
    dec_rate: float = 0.0  # degrees/s: a declination rate offset
    pending: list[tuple[float, float, float, float]] = field(default_factory=list)  # start, end, dra/s, ddec/s

    def predict(self, now: float) -> tuple[float, float] | None:
        if self.anchor_ra is None or self.anchor_dec is None:
            return None
        ra = self.anchor_ra + self.ra_rate * (now - self.anchor_time)
        dec = self.anchor_dec + self.dec_rate * (now - self.anchor_time)
        for start, end, dra, ddec in self.pending:
            span = max(0.0, min(now, end) - max(start, self.anchor_time))
            ra += dra * span
            dec += ddec * span
        return ra % 24.0, dec

    def _rebase(self, now: float) -> None:
        predicted = self.predict(now)
        if predicted is not None:
            self.anchor_ra, self.anchor_dec = predicted
        self.anchor_time = now
        self.pending = [p for p in self.pending if p[1] > now]

    def set_exact(self, ra: float, dec: float, now: float) -> None:
        self.anchor_ra, self.anchor_dec, self.anchor_time = ra % 24.0, dec, now
        self.pending = []

    def set_ra_rate(self, ra_rate: float, now: float) -> None:
        self._rebase(now)
        self.ra_rate = ra_rate

    def set_dec_rate(self, dec_rate: float, now: float) -> None:
        self._rebase(now)
        self.dec_rate = dec_rate

    def add_motion(self, start: float, end: float, dra_per_s: float, ddec_per_s: float) -> None:
        # Fold finished motions into the anchor first, so a night of guide pulses keeps at most the
        # ones still running here (predict() runs on every coordinate read).
        self._rebase(start)
        self.pending.append((start, end, dra_per_s, ddec_per_s))

    def shift_ra(self, hours: float) -> None:
        """Every RA reading moved by ``hours`` (a new longitude moves the sidereal time under a still
        mount): the estimate moves with them and keeps its precision, if the next reading agrees."""
        if self.anchor_ra is not None:
            self.anchor_ra = (self.anchor_ra + hours) % 24.0

    def invalidate(self) -> None:
        self.anchor_ra = self.anchor_dec = None
        self.pending = []

    def in_motion(self, now: float) -> bool:
        """Whether a motion the estimator carries (a guide pulse) is still running."""
        return any(end > now for _, end, _, _ in self.pending)

    def observe(self, raw_ra: float, raw_dec: float, now: float, asked: float | None = None) -> tuple[float, float]:
        """The best position given a reading that arrived at ``now``.

        The mount took the reading at some instant between ``asked`` (just before the query was sent)
        and ``now``; over WiFi, or on a loaded host, that can be a tenth of a second or more before
        ``now``, and during a guide pulse the sky moves 1″ in that time. So a reading agrees with the
        estimate if it does at *some* instant of that window, and one that disagrees corrects the
        estimate as of the window's middle, keeping the motion since. A reading taken while the
        estimate's rates changed (its anchor moved inside the window) cannot be placed against the
        change: the next one judges. An anchor set at the reading's own arrival (the poll that brought
        it booked the GOTO target or a tracking change) is judged there, at ``now``.
        """
        predicted = self.predict(now)
        if predicted is None:
            self.set_exact(raw_ra, raw_dec, now)
            return raw_ra, raw_dec
        start = now if asked is None else min(asked, now)
        if start < self.anchor_time:
            if self.anchor_time < now:
                return predicted
            start = now
        instants = [start, now] + [t for motion in self.pending for t in motion[:2] if start < t < now]
        ra_off: list[float] = []
        dec_off: list[float] = []
        for instant in instants:
            then = self.predict(instant)
            assert then is not None
            ra_off.append(_wrap12(then[0] - raw_ra))
            dec_off.append(then[1] - raw_dec)
        ra_ok = min(ra_off) <= self.ra_tolerance_h and max(ra_off) >= -self.ra_tolerance_h
        dec_ok = min(dec_off) <= self.dec_tolerance_deg and max(dec_off) >= -self.dec_tolerance_deg
        if ra_ok and dec_ok:
            return predicted
        middle = self.predict((start + now) / 2.0)
        assert middle is not None
        # Re-anchor only the axis the reading contradicts, keeping motions still in flight (the rest
        # of a guide pulse): a Dec correction must not move RA, nor drop the rest of a pulse.
        self._rebase(now)
        assert self.anchor_ra is not None and self.anchor_dec is not None
        if not ra_ok:
            self.anchor_ra = (self.anchor_ra + _wrap12(raw_ra - middle[0])) % 24.0
        if not dec_ok:
            self.anchor_dec += raw_dec - middle[1]
        return self.anchor_ra % 24.0, self.anchor_dec
