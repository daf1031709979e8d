"""Finding SafetyMonitor and Dome devices on the LAN by Alpaca discovery, for the setup page.

Only ever run when the user presses the page's button (never at start or on a timer): it sends the
``alpacadiscovery1`` query by UDP broadcast to port 32227 on each of this machine's IPv4 networks
(their directed broadcast addresses, read locally by ``local_addresses``), or by unicast to one host
the user names (a monitor on another subnet, where a broadcast does not reach). Every server answers
with its HTTP port; each is then asked for its devices by the management API
(``/management/v1/configureddevices``). A server without the management API (alpaca-simulators, for
one) is asked for ``safetymonitor/N`` and ``dome/N`` by number instead, until the first that is not
there. IPv6 discovery (multicast ``ff12::a1:9aca``) is not sent: a LAN monitor answers on IPv4.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import logging
import socket
import time
from collections.abc import Iterable
from dataclasses import dataclass, field

from .discovery import DEFAULT_DISCOVERY_PORT, DISCOVERY_MESSAGE
from .local_addresses import interface_networks
from .remote import RemoteDevice, RemoteError, get_json

__all__ = ["FoundDevice", "FoundServer", "broadcast_targets", "discover_servers", "find_devices"]

log = logging.getLogger(__name__)

#: The device types the observatory interlock reads, as the management API spells them.
WANTED_TYPES = ("SafetyMonitor", "Dome")
#: Device numbers probed on a server without the management API.
PROBE_NUMBERS = 4
HTTP_TIMEOUT_S = 3.0


@dataclass(frozen=True)
class FoundDevice:
    type: str  # "SafetyMonitor" or "Dome"
    number: int
    name: str
    url: str  # what the [safety] monitor or roof setting takes


@dataclass
class FoundServer:
    address: str  # host:port of its HTTP API
    name: str = ""
    devices: list[FoundDevice] = field(default_factory=list)
    other_devices: int = 0  # telescopes, cameras ...: not usable here
    error: str = ""


def broadcast_targets() -> list[str]:
    """The directed broadcast address of each of this machine's IPv4 networks (none wider than /8)."""
    targets = [str(n.broadcast_address) for n in interface_networks()
               if isinstance(n, ipaddress.IPv4Network) and 8 <= n.prefixlen <= 30]
    return list(dict.fromkeys(targets))


def discover_servers(targets: Iterable[str], port: int = DEFAULT_DISCOVERY_PORT,
                     timeout: float = 2.0) -> list[tuple[str, int]]:
    """Send one discovery query to each target and collect (address, AlpacaPort) until ``timeout``."""
    found: dict[tuple[str, int], None] = {}
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
        for target in targets:
            try:
                sock.sendto(DISCOVERY_MESSAGE, (target, port))
            except OSError as exc:  # no route to that network: the others still count
                log.info("discovery query to %s failed: %s", target, exc)
        deadline = time.monotonic() + timeout
        while (remaining := deadline - time.monotonic()) > 0:
            sock.settimeout(remaining)
            try:
                data, (address, _) = sock.recvfrom(1024)
            except TimeoutError:
                break
            with contextlib.suppress(ValueError, TypeError, AttributeError):
                alpaca_port = json.loads(data).get("AlpacaPort")
                if isinstance(alpaca_port, int) and not isinstance(alpaca_port, bool) and 0 < alpaca_port < 65536:
                    found[(address, alpaca_port)] = None
    return list(found)


def _base(address: str, port: int) -> str:
    host = f"[{address}]" if ":" in address else address
    return f"http://{host}:{port}"


def _listed(server: FoundServer, base: str) -> None:
    """The devices from the management API; raises RemoteError when the server has none."""
    reply = get_json(f"{base}/management/v1/configureddevices", HTTP_TIMEOUT_S)
    devices = reply.get("Value") if isinstance(reply, dict) else None
    if not isinstance(devices, list):
        raise RemoteError("configureddevices: not an Alpaca reply")
    for entry in devices:
        if not isinstance(entry, dict):
            continue
        kind, number = str(entry.get("DeviceType", "")), entry.get("DeviceNumber")
        wanted = next((t for t in WANTED_TYPES if t.lower() == kind.lower()), None)
        if wanted is None or not isinstance(number, int) or isinstance(number, bool) or number < 0:
            server.other_devices += 1
            continue
        server.devices.append(FoundDevice(wanted, number, str(entry.get("DeviceName", "")),
                                          f"{base}/api/v1/{wanted.lower()}/{number}"))
    with contextlib.suppress(RemoteError):
        description = get_json(f"{base}/management/v1/description", HTTP_TIMEOUT_S)
        value = description.get("Value") if isinstance(description, dict) else None
        if isinstance(value, dict):
            server.name = str(value.get("ServerName", ""))


def _probed(server: FoundServer, base: str) -> None:
    """No management API: ask for each wanted type by number until one is not there."""
    for kind in WANTED_TYPES:
        for number in range(PROBE_NUMBERS):
            url = f"{base}/api/v1/{kind.lower()}/{number}"
            try:
                name = RemoteDevice(url, client_id=1, timeout=HTTP_TIMEOUT_S).get("name")
            except RemoteError:
                break
            server.devices.append(FoundDevice(kind, number, str(name), url))


def find_devices(host: str = "", port: int = DEFAULT_DISCOVERY_PORT, timeout: float = 2.0) -> list[FoundServer]:
    """Discover Alpaca servers (broadcast, or unicast to ``host``) and list their SafetyMonitors and Domes."""
    targets = [host] if host else broadcast_targets()
    servers = []
    for address, alpaca_port in sorted(discover_servers(targets, port, timeout)):
        base = _base(address, alpaca_port)
        server = FoundServer(f"{address}:{alpaca_port}")
        try:
            _listed(server, base)
        except RemoteError as exc:
            _probed(server, base)
            if not server.devices:
                server.error = f"no device list (management API: {exc})"
        servers.append(server)
    return servers
