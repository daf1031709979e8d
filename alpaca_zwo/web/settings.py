"""The settings API: ``/setup/api/telescope/{number}/settings`` and ``/setup/api/server``.

A change is a JSON object of groups. Each group has one entry in a table: the file-held groups
(``site``, ``park``, ``limits``, ``safety``, ``time``, ``device``) are merged into the settings file, the
mount-held ones (``meridian``, ``mount_limits``, ``heavy_duty``, ``buzzer``, ``mode``) become checked
commands for the mount. Everything is checked before anything is applied, so a typo in one field
never leaves the mount changed and the file not (or the reverse). The file is written first, in one
atomic update, so a failed save (full disk) changes nothing; if the mount then refuses, the file
groups are put back. The mount-held values are checked, written (and the meridian setting mirrored in
the file) by their one owner, ``telescope/stored_settings.py``, through the facade, as the Actions and
the shared ZWO port do.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import falcon

from ..facade import (
    DeviceFacade,
    MeridianSettings,
    MountSettings,
    ServerFacade,
    Settings,
    check_stored_setting,
    settings_from_dict,
    settings_to_dict,
)
from ..sky import SIDEREAL_DEG_S
from .context import Resource, WebContext
from .http import ApiError, api_errors, check_same_origin, number, obj, only_keys, send

log = logging.getLogger(__name__)

#: Manual-move speeds the page offers, as multiples of sidereal (the mount's :R0..:R9 set minus 0.25x).
JOG_MULTIPLES = (0.5, 1.0, 2.0, 4.0, 8.0, 20.0, 60.0, 720.0, 1440.0)
#: Groups stored in the settings file.
FILE_GROUPS = ("site", "park", "limits", "safety", "time", "device")
#: What each site key may be; checked before anything is saved, so a bad longitude cannot leave a
#: new latitude half-applied.
SITE_RANGES = {"latitude": (-90.0, 90.0), "longitude": (-180.0, 180.0), "elevation": (-300.0, 10000.0)}
SERVER_KEYS = frozenset({"host", "port", "discovery_port", "mdns", "location", "allowed_hosts", "allowed_networks"})
#: Server keys in effect at once (the host guard follows the store, the bridges read theirs on each
#: connection); the others after a restart.
LIVE_SERVER_KEYS = frozenset({"allowed_hosts", "allowed_networks"})
#: The bridges whose ``allowed_networks`` the page edits (``allowed_networks`` in a server change).
BRIDGE_SECTIONS = ("zwo_port", "stellarium")

MountCommand = tuple[str, Any]
#: A mount-held group's checker: (device, the group's value) -> the commands to send, in order.
MountGroup = Callable[[DeviceFacade, Any], list[MountCommand]]


def _stored(name: str, key: str, value: Any) -> Any:
    """A value of a setting stored in the mount, by the one check its owner keeps (400 with the reason)."""
    try:
        return check_stored_setting(name, value)
    except ValueError as exc:
        raise ApiError(400, f"{key} {exc}") from None


def _meridian(device: DeviceFacade, raw: Any) -> list[MountCommand]:
    group = obj(raw, "meridian")
    cached = device.cached_mount_settings
    flip = cached.meridian.flip if cached is not None and cached.meridian is not None else False
    track_after = _stored("meridian.track_after", "track_after", group.get("track_after"))
    limit = _stored("meridian.limit_degrees", "limit_degrees", group.get("limit_degrees"))
    return [("meridian", MeridianSettings(flip=flip, track_after=track_after, limit_degrees=limit))]


#: The page's mount_limits keys and the stored settings they are, in the order they are written.
LIMIT_KEYS = {"upper": "upper_limit", "lower": "lower_limit", "enabled": "limits_enabled"}


def _mount_limits(device: DeviceFacade, raw: Any) -> list[MountCommand]:
    group = obj(raw, "mount_limits")
    only_keys(group, set(LIMIT_KEYS), "mount_limits key(s)")
    return [(name, _stored(name, key, group[key])) for key, name in LIMIT_KEYS.items() if key in group]


def _heavy_duty(device: DeviceFacade, raw: Any) -> list[MountCommand]:
    return [("heavy_duty", _stored("heavy_duty", "heavy_duty", raw))]


def _buzzer(device: DeviceFacade, raw: Any) -> list[MountCommand]:
    return [("buzzer", _stored("buzzer", "buzzer", raw))]


def _mode(device: DeviceFacade, raw: Any) -> list[MountCommand]:
    """EQ/alt-az: sent now, in effect only after the mount is restarted (the view says so)."""
    if raw not in ("equatorial", "altaz"):
        raise ApiError(400, 'mode must be "equatorial" or "altaz"')
    return [("mode", raw)]


#: The mount-held groups, in the order their commands are sent.
MOUNT_GROUPS: dict[str, MountGroup] = {
    "meridian": _meridian,
    "mount_limits": _mount_limits,
    "heavy_duty": _heavy_duty,
    "buzzer": _buzzer,
    "mode": _mode,
}


@dataclass
class SettingsChange:
    """A checked change, ready to apply: file groups to merge, the device entry, the site, mount commands."""

    file_groups: dict[str, dict[str, Any]] = field(default_factory=dict)
    device: dict[str, Any] | None = None
    site: dict[str, float] = field(default_factory=dict)
    mount: list[MountCommand] = field(default_factory=list)

    @property
    def touches_file(self) -> bool:
        return bool(self.file_groups) or self.device is not None


def plan_change(device: DeviceFacade, body: dict[str, Any]) -> SettingsChange:
    """Check every group of ``body``; raise ApiError before anything is applied."""
    only_keys(body, set(FILE_GROUPS) | set(MOUNT_GROUPS), "settings group(s)")
    file_groups = {name: obj(body[name], name) for name in FILE_GROUPS if name in body}
    mount_groups = [name for name in MOUNT_GROUPS if name in body]
    if mount_groups and not device.running:
        raise ApiError(409, "these settings are stored in the mount: connect the mount first")
    # A meridian setting is mirrored in the file by the stored settings' owner, as it writes it.
    commands = [command for name in mount_groups for command in MOUNT_GROUPS[name](device, body[name])]
    site = file_groups.pop("site", {})
    only_keys(site, set(SITE_RANGES), "site key(s)")
    entry = file_groups.pop("device", None)
    if entry is not None and set(entry) - {"name"}:
        raise ApiError(400, "only the device name can be changed here")
    return SettingsChange(file_groups, entry, {k: number(site, k, *SITE_RANGES[k]) for k in SITE_RANGES if k in site},
                          commands)


def _merged(change: SettingsChange, index: int) -> Callable[[Settings], Settings]:
    def merge(current: Settings) -> Settings:
        data = settings_to_dict(current)
        for name, group in change.file_groups.items():
            data[name] = {**data[name], **group}
        if change.device is not None:
            data["devices"][index] = {**data["devices"][index], **change.device}
        return settings_from_dict(data, "setup page")

    return merge


def _restored(change: SettingsChange, index: int, previous: Settings) -> Callable[[Settings], Settings]:
    """Put back the file groups ``change`` wrote (after the mount refused), leaving any others as they are."""
    old = settings_to_dict(previous)

    def restore(current: Settings) -> Settings:
        data = settings_to_dict(current)
        for name in change.file_groups:
            data[name] = old[name]
        if change.device is not None:
            data["devices"][index] = old["devices"][index]
        return settings_from_dict(data, "setup page")

    return restore


def change_settings(web: WebContext, device: DeviceFacade, body: dict[str, Any]) -> MountSettings | None:
    """Apply the groups present in ``body``, all or nothing as far as validation can tell.

    Order: check everything, save the file, then set the mount and the site. A save that fails
    (full disk, read-only directory) therefore changes nothing (SettingsNotSaved, HTTP 507); a mount
    that refuses gets the file groups put back before the error is shown.
    """
    change = plan_change(device, body)
    merge = _merged(change, device.index)
    with web.settings_lock:
        previous = web.facade.settings
        if change.touches_file:
            try:
                merge(previous)  # dry run: refuse bad values before anything is touched
            except (TypeError, ValueError) as exc:
                raise ApiError(400, f"invalid setting: {exc}") from None
            web.facade.update_settings(merge)
        try:
            device.apply_mount_settings({name: value for name, value in change.mount if name != "mode"})
            for name, value in change.mount:
                if name == "mode":
                    device.request_mode(value)
            if change.site:
                device.set_site(change.site)
        except Exception:
            if change.touches_file:
                web.facade.update_settings(_restored(change, device.index, previous))
            raise
    mount_held = any(name in body for name in MOUNT_GROUPS)
    return device.read_mount_settings() if mount_held else device.cached_mount_settings


def settings_view(facade: ServerFacade, device: DeviceFacade, mount: MountSettings | None) -> dict[str, Any]:
    settings = facade.settings
    limits = settings.limits
    return {
        "device": {"name": device.name, "unique_id": device.unique_id, "url": device.url or "(built-in emulator)"},
        "connected": device.running,
        "mount": _mount_view(mount),
        # {"mode", "requested", "restart_required", "message"}: the page shows the restart warning.
        "mode": device.mount_mode(),
        "site": dataclasses.asdict(settings.site),
        "park": dataclasses.asdict(settings.park),
        "limits": {"min_altitude_deg": limits.min_altitude_deg,
                   "horizon": [list(p) for p in limits.horizon],
                   "meridian_limit_deg": limits.meridian_limit_deg,
                   "meridian_track_past": limits.meridian_track_past},
        # Whose clock wins (auto | host | mount): read by the time keeper on each decision, so in effect at once.
        "time": {"source": settings.time.source},
        "safety": {"moveaxis_watchdog_s": settings.safety.moveaxis_watchdog_s,
                   "on_shutdown": settings.safety.on_shutdown, "monitor": settings.safety.monitor,
                   "roof": settings.safety.roof, "poll_s": settings.safety.poll_s,
                   "unreachable_s": settings.safety.unreachable_s, "on_unsafe": settings.safety.on_unsafe},
    }


def _mount_view(mount: MountSettings | None) -> dict[str, Any] | None:
    if mount is None:
        return None
    meridian = mount.meridian
    return {
        "meridian": dataclasses.asdict(meridian) if meridian is not None else None,
        "limits_enabled": mount.limits_enabled, "upper_limit": mount.upper_limit,
        "lower_limit": mount.lower_limit, "heavy_duty": mount.heavy_duty, "buzzer": mount.buzzer,
        "guide_rate": mount.guide_rate,
    }


class SettingsResource(Resource):
    """``/setup/api/telescope/{number}/settings``: GET reads (the mount's own settings too), POST changes.

    The GET sends nothing to the mount: its settings come from the copy the server keeps
    (``DeviceFacade.cached_mount_settings``), so any number of open pages cost the serial line nothing.
    """

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            device = self.web.device(number)
            send(resp, settings_view(self.web.facade, device, device.cached_mount_settings))

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            device = self.web.device(number)
            self.web.touch(req)
            mount = change_settings(self.web, device, body)
            log.info("setup page (%s): settings changed: %s", req.remote_addr, ", ".join(sorted(body)) or "nothing")
            send(resp, settings_view(self.web.facade, device, mount))


# --- the server's own settings -------------------------------------------------------------------


def server_view(facade: ServerFacade) -> dict[str, Any]:
    """Who this server is (and what it will be after a restart)."""
    net = facade.settings.server
    return {
        "name": "alpaca-zwo",
        "manufacturer": "alpaca-zwo project",
        "version": facade.version,
        "location": net.location,
        "port": facade.port,
        "discovery_port": facade.discovery_port,
        "connect": facade.connect_info(),  # in effect now, apart from "configured" (after a restart)
        "configured": {"host": net.host, "port": net.port, "discovery_port": net.discovery_port,
                       "mdns": net.mdns},
        # The DNS-rebinding guard: names added by the user ("*": no guard) and those always allowed.
        "allowed_hosts": list(net.allowed_hosts),
        "host_names": facade.host_names(),
        # Who may connect to each bridge ("local" = loopback and local_networks, listed as they are now).
        "allowed_networks": {name: list(getattr(facade.settings, name).allowed_networks) for name in BRIDGE_SECTIONS},
        "local_networks": facade.local_networks(),
        "config_file": str(facade.config_file) if facade.config_file else None,
        "basic_auth": bool(net.basic_auth_user),
        "devices": [{"number": d.index, "name": d.name, "unique_id": d.unique_id} for d in facade.devices()],
        "jog_multiples": list(JOG_MULTIPLES),
        "sidereal_deg_s": SIDEREAL_DEG_S,
        "bridges": facade.bridges(),
    }


def change_server(facade: ServerFacade, body: dict[str, Any]) -> None:
    only_keys(body, SERVER_KEYS, "server setting(s)")
    _check_listen(facade, body)
    server = dict(body)
    networks = obj(server.pop("allowed_networks"), "allowed_networks") if "allowed_networks" in body else {}
    only_keys(networks, set(BRIDGE_SECTIONS), "allowed_networks bridge(s)")

    def change(current: Settings) -> Settings:
        data = settings_to_dict(current)
        data["server"] = {**data["server"], **server}
        for name, entries in networks.items():
            data[name] = {**data[name], "allowed_networks": entries}
        return settings_from_dict(data, "setup page")

    facade.update_settings(change)
    when = "after a restart" if restart_required(body) else "now"
    log.info("setup page: server settings changed (%s); in effect %s", ", ".join(sorted(body)), when)


def _check_listen(facade: ServerFacade, body: dict[str, Any]) -> None:
    """A new host or port is saved only if the next start can listen there (it would fail otherwise,
    and the page that could undo it would be gone): an address of this machine, 0.0.0.0 or ::, and a
    port free to bind or the one in use now."""
    if "host" not in body and "port" not in body:
        return
    host = body.get("host", facade.settings.server.host)
    port = body.get("port", facade.settings.server.port)
    if not isinstance(host, str):
        raise ApiError(400, "host must be a string: 0.0.0.0, :: or an address of this machine")
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ApiError(400, "port must be a whole number from 0 to 65535")
    problem = facade.listen_problem(host, port)
    if problem is not None:
        raise ApiError(400, f"not saved: {problem}")


def restart_required(body: dict[str, Any]) -> bool:
    return bool(set(body) - LIVE_SERVER_KEYS)


class ServerResource(Resource):
    """``/setup/api/server``: who this server is; POST changes the network settings (applied on restart)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        send(resp, server_view(self.web.facade))

    def on_post(self, req: falcon.Request, resp: falcon.Response) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            change_server(self.web.facade, body)
            send(resp, {**server_view(self.web.facade), "restart_required": restart_required(body)})
