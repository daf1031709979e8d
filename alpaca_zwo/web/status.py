"""The status feed: ``GET /setup/api/telescope/{number}/status``, polled about once a second.

N.I.N.A. disables its own setup button while it is connected, so the page has to work alongside
imaging clients: every value here is built from snapshots the mount poller already keeps (a page
open on a phone must never add serial traffic or wait behind a GOTO).
"""

from __future__ import annotations

import time
from datetime import datetime, timezone
from typing import Any

import falcon

from ..facade import (
    ClientKey,
    ClockView,
    DeviceFacade,
    MotionReport,
    MotionView,
    MountState,
    ServerFacade,
    Settings,
    horizon_altitude_at,
)
from ..sky import SOLAR_SECONDS_PER_SIDEREAL_SECOND, equatorial_to_horizontal, hour_angle, local_sidereal_time
from .context import Resource
from .http import PAGE_TAG, api_errors, finite, iso, send

#: Seconds a client stays in the page's client list after its last request.
CLIENT_WINDOW_S = 300.0
TRACKING_RATE_NAMES = {0: "sidereal", 1: "lunar", 2: "solar"}
PIER_NAMES = {0: "east", 1: "west"}


class StatusResource(Resource):
    """``GET /setup/api/telescope/{number}/status``: one coherent picture for the page."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            key = self.web.touch(req)
            send(resp, status_view(self.web.facade, device, key))


def status_view(facade: ServerFacade, device: DeviceFacade, page_key: ClientKey) -> dict[str, Any]:
    """From snapshots only: nothing here waits for the mount."""
    settings = facade.settings
    state = device.state
    now = device.utc_now()
    lst = local_sidereal_time(now, settings.site.longitude)
    connected_keys = device.connected_clients()
    motion = device.motion()
    ha = hour_angle(lst, state.ra) if state.ra is not None and state.dec is not None else None
    pier = _pier(motion.side_of_pier) if device.running else None
    tracking = bool(state.tracking and state.tracking.on)
    meridian = meridian_view(facade, device, ha, tracking and pier == "west")
    report = motion_report_view(device.motion_report(), lst, settings.site.latitude, state)
    return {
        "device": device.index,
        "name": device.name,
        "time": {"utc": iso(now), "lst": finite(lst, 7),
                 "offset_s": finite((now - datetime.now(timezone.utc)).total_seconds(), 3),
                 **clock_view(device.clock())},
        "site": site_view(facade),
        "connected": device.running,
        "page_connected": page_key in connected_keys,
        "mount": {"model": state.info.model, "firmware": state.info.firmware} if state.info else None,
        "initialised": state.initialised,
        "link": link_view(device),
        "position": position_view(settings, device, state, ha),
        # A park's or home's own position while it runs, not the last GoTo's target (TargetRightAscension).
        "target": ((report["target"] if report and report["active"] else None)
                   or (target_view(device, lst, settings.site.latitude) if motion.slewing else None)),
        "motion": report,
        "pier_side": pier,
        "pier_letter": state.pier,
        **_motion_view(state, motion, tracking),
        "flags": flags_view(state),
        "meridian": meridian,
        "clients": clients_view(facade, connected_keys),
        "sky": sky_view(settings, device, meridian["limit_deg"]),
        "bridges": facade.bridges(),
        "safety": facade.safety(),  # the observatory interlock (docs/guide/observatory.md)
    }


def clock_view(clock: ClockView) -> dict[str, Any]:
    """Which clock the server keeps and why, and the host clock's standing (mount/timekeeping.py)."""
    last = clock.host_last_synchronised
    return {"source": clock.source.value, "reason": clock.reason, "policy": clock.policy,
            "host_offset_s": finite(clock.offset_s, 3), "host_synchronised": clock.host.synchronised,
            "host_status": clock.host.detail, "host_last_synchronised": iso(last) if last else None,
            "decided_at": iso(clock.decided_at) if clock.decided_at else None}


def site_view(facade: ServerFacade) -> dict[str, Any]:
    """The site in use, whether it is still the factory default, and the GPS receiver's state (site.gpsd)."""
    site = facade.settings.site
    return {"latitude": site.latitude, "longitude": site.longitude, "elevation": site.elevation,
            "default": site.is_default, "gps": facade.gps()}


def _pier(code: int | None) -> str | None:
    return PIER_NAMES.get(code, "unknown") if code is not None else None


def _motion_view(state: MountState, motion: MotionView, tracking: bool) -> dict[str, Any]:
    rate = motion.tracking_rate
    return {
        "tracking": tracking,
        "tracking_rate": rate,
        "tracking_rate_name": TRACKING_RATE_NAMES.get(rate) if rate is not None else None,
        "tracking_stopped": state.tracking.reason if state.tracking and state.tracking.error else "",
        "slewing": motion.slewing,
        "moving_axes": sorted(state.moving_axes),
        "guiding": motion.guiding,
        "guide_rate": finite(state.guide_rate, 3),
        "at_park": motion.at_park,
        "parked_by_mount": state.parked_by_mount,  # its own park (ZWO app, ASIAIR...): the page says so
        "at_home": motion.at_home,
    }


def position_view(settings: Settings, device: DeviceFacade, state: MountState,
                  ha: float | None) -> dict[str, Any] | None:
    if ha is None or state.ra is None or state.dec is None:
        return None
    alt, az = equatorial_to_horizontal(ha, state.dec, settings.site.latitude)
    floor = horizon_altitude_at(settings.limits, az)
    # Snapshot times are on the mount's own clock (the emulator's, when it runs fast).
    return {"ra": finite(state.ra, 7), "dec": finite(state.dec), "ha": finite(ha), "alt": finite(alt),
            "az": finite(az), "floor": finite(floor, 3), "below_limit": alt < floor,
            "age_s": finite(state.age(device.mount_now()), 3)}


def motion_report_view(report: MotionReport | None, lst: float, latitude: float,
                       state: MountState) -> dict[str, Any] | None:
    """The running (or last) slew, park or home: its kind, target and how it ended, for the progress line."""
    if report is None:
        return None
    ra, dec = report.ra, report.dec
    if report.ha is not None:
        ra = (lst - report.ha) % 24.0
    elif ra is None and state.status is not None and state.status.mode.name.lower() != "altaz":
        ra, dec = lst, 90.0 if latitude >= 0 else -90.0  # home (and park at home): at the pole
    target = None
    if ra is not None and dec is not None:
        alt, az = equatorial_to_horizontal(hour_angle(lst, ra), dec, latitude)
        target = {"ra": finite(ra, 7), "dec": finite(dec), "alt": finite(alt), "az": finite(az)}
    return {"kind": report.kind, "active": report.active, "error": report.error, "target": target}


def target_view(device: DeviceFacade, lst: float, latitude: float) -> dict[str, Any] | None:
    target = device.target()
    if target is None:
        return None
    ra, dec = target
    alt, az = equatorial_to_horizontal(hour_angle(lst, ra), dec, latitude)
    return {"ra": finite(ra, 7), "dec": finite(dec), "alt": finite(alt), "az": finite(az)}


def link_view(device: DeviceFacade) -> dict[str, Any]:
    view = device.link()
    link, counters = view.status, view.counters
    return {
        "state": link.state.value, "url": link.url, "emulated": device.emulated,
        "since": link.since, "last_error": link.last_error,
        "reconnects": link.reconnects, "generation": link.generation, "poll_error": view.poll_error,
        "exchanges": counters.exchanges, "timeouts": counters.timeouts, "resyncs": counters.resyncs,
        "bytes_in": counters.bytes_in, "bytes_out": counters.bytes_out,
    }


def flags_view(state: MountState) -> dict[str, Any]:
    flags = state.status
    return {
        "low_voltage": bool(flags and flags.low_voltage),
        "ra_stall": bool(flags and flags.ra_stall),
        "dec_stall": bool(flags and flags.dec_stall),
        "mode": flags.mode.name.lower() if flags else None,
    }


def meridian_view(facade: ServerFacade, device: DeviceFacade, ha: float | None,
                  counting_down: bool) -> dict[str, Any]:
    """The flip line in force (by the mount's own setting when known) and the time left to reach it:
    the line the Telescope predicts flips with (DestinationSideOfPier), by the same rule."""
    track_after, effective = device.flip_line()
    minutes = None
    if counting_down and ha is not None:
        # HA grows one sidereal hour per 0.99727 solar hours while tracking.
        minutes = (effective / 15.0 - ha) * 60.0 * SOLAR_SECONDS_PER_SIDEREAL_SECOND
    return {"track_after": track_after, "limit_deg": effective, "minutes_to_limit": finite(minutes, 1)}


def clients_view(facade: ServerFacade, connected: frozenset[ClientKey]) -> list[dict[str, Any]]:
    now = time.monotonic()
    rows = []
    for activity in facade.client_activity(CLIENT_WINDOW_S, now):
        key = activity.key
        page = key.address.startswith(PAGE_TAG)
        rows.append({
            "address": key.address.removeprefix(PAGE_TAG) if page else key.address,
            "client_id": key.client_id,
            "setup_page": page,
            "connected": key in connected,
            "user_agent": activity.user_agent,
            "requests": activity.requests,
            "idle_s": round(max(0.0, now - activity.last_seen), 1),
        })
    return rows


def sky_view(settings: Settings, device: DeviceFacade, limit_deg: float) -> dict[str, Any]:
    """What the all-sky plot draws besides the telescope: the allowed horizon and the flip line."""
    latitude = settings.site.latitude
    floor = [[az, round(horizon_altitude_at(settings.limits, az), 3)] for az in range(0, 360, 3)]
    flip_line: list[list[float]] = []
    if limit_deg:
        for dec10 in range(-900, 901, 25):
            alt, az = equatorial_to_horizontal(limit_deg / 15.0, dec10 / 10.0, latitude)
            if alt > -5.0:
                flip_line.append([round(az, 3), round(alt, 3)])
    cached = device.cached_mount_settings
    mount_limits = None
    if cached is not None and cached.limits_enabled:
        mount_limits = {"lower": cached.lower_limit, "upper": cached.upper_limit}
    return {"latitude": latitude, "floor": floor, "min_altitude": settings.limits.min_altitude_deg,
            "flip_line": flip_line, "pole": [0.0 if latitude >= 0 else 180.0, abs(latitude)],
            "mount_limits": mount_limits}
