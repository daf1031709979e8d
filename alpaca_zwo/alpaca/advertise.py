"""Optional mDNS/DNS-SD advertisement of the setup web page (``--mdns``).

Alpaca clients do not use mDNS (they use UDP discovery, see ``discovery.py``); this exists so a
person with a phone or a service browser can find the setup page as ``_http._tcp`` without
knowing the host's address. It is off by default because multicast chatter on an observatory LAN
should be opt-in, and zeroconf is imported only when an advertiser actually starts so that the
default path pays nothing for it.
"""

from __future__ import annotations

import ipaddress
import logging
import re
import socket
import threading
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from zeroconf import ServiceInfo

__all__ = ["SERVICE_TYPE", "SETUP_PATH", "MdnsAdvertiser"]

log = logging.getLogger(__name__)

SERVICE_TYPE = "_http._tcp.local."
SETUP_PATH = "/setup"

_MAX_LABEL_BYTES = 63  # DNS label limit, which DNS-SD instance names share


def _truncate_label(text: str) -> str:
    """Cut ``text`` to 63 UTF-8 bytes without splitting a character."""
    return text.encode("utf-8")[:_MAX_LABEL_BYTES].decode("utf-8", "ignore")


def _host_label(hostname: str) -> str:
    """Turn the machine's host name into one lowercase DNS label."""
    label = re.sub(r"[^a-z0-9-]+", "-", hostname.split(".", 1)[0].lower()).strip("-")
    return label or "host"


def _default_addresses() -> list[str]:
    """Addresses worth publishing: every non-loopback IPv4 address and routable IPv6 address.

    IPv6 link-local addresses are left out because an AAAA record cannot carry the scope needed to
    use them. ifaddr is what zeroconf itself uses (and depends on) to enumerate interfaces.
    """
    import ifaddr

    found: list[str] = []
    for adapter in ifaddr.get_adapters():
        for ip in adapter.ips:
            raw = ip.ip if isinstance(ip.ip, str) else ip.ip[0]
            try:
                addr = ipaddress.ip_address(raw)
            except ValueError:
                continue
            if addr.is_loopback or (addr.version == 6 and addr.is_link_local):
                continue
            if str(addr) not in found:
                found.append(str(addr))
    return found


class MdnsAdvertiser:
    """Advertises ``<server_name>._http._tcp.local.`` pointing at the setup page.

    The TXT record carries ``path=/setup`` (the DNS-SD convention for an HTTP service's page) and
    ``alpaca=1`` so a browser can tell this apart from any other web server on the LAN.

    ``addresses`` pins the published addresses and, for the IPv4 ones, the interfaces mDNS runs on,
    matching a server bound to selected interfaces. When None, all host addresses are published
    as they are at ``start()``; later address changes are not followed.

    The SRV target is a dedicated host name (``<host>-alpaca-zwo.local.``) rather than the
    machine's own, so this never answers for a name that avahi or mDNSResponder already defends.
    """

    def __init__(self, http_port: int, server_name: str, addresses: list[str] | None = None) -> None:
        if not 1 <= http_port <= 65535:
            raise ValueError(f"http_port out of range: {http_port}")
        # python-zeroconf does not escape dots inside an instance name, so a dot would split it into
        # two DNS labels and browsers would show only the tail.
        name = _truncate_label(server_name.strip().replace(".", "-"))
        if not name:
            raise ValueError("server_name must not be empty")
        if addresses is not None:
            for address in addresses:
                ipaddress.ip_address(address)  # fail at construction, not on a background start
        self.http_port = http_port
        self.server_name = name
        self.addresses = list(addresses) if addresses is not None else None
        self.host_name = f"{_host_label(socket.gethostname())}-alpaca-zwo.local."
        self._lock = threading.Lock()
        self._zeroconf: Any = None
        self._info: ServiceInfo | None = None

    @property
    def running(self) -> bool:
        """True while the service is registered."""
        return self._zeroconf is not None

    @property
    def registered_name(self) -> str | None:
        """The instance name actually registered; zeroconf renames it on a conflict."""
        return self._info.name if self._info is not None else None

    def service_info(self) -> ServiceInfo:
        """Build the record set to publish; separate from ``start()`` so it can be inspected."""
        from zeroconf import ServiceInfo

        addresses = self.addresses if self.addresses is not None else _default_addresses()
        if not addresses:
            log.warning("mDNS: no usable address found; the service will not resolve to a host")
        return ServiceInfo(
            SERVICE_TYPE,
            f"{self.server_name}.{SERVICE_TYPE}",
            port=self.http_port,
            properties={"path": SETUP_PATH, "alpaca": "1"},
            server=self.host_name,
            parsed_addresses=addresses,
        )

    def start(self) -> None:
        """Register the service (blocks for the ~1-2 s of mDNS probing); no-op when running.

        Raises OSError when no multicast-capable interface can be opened, so the caller decides
        whether a missing advertisement is worth failing over.
        """
        with self._lock:
            if self._zeroconf is not None:
                return
            from zeroconf import InterfaceChoice, Zeroconf

            info = self.service_info()
            v4_interfaces = [a for a in self.addresses or () if ipaddress.ip_address(a).version == 4]
            zc = Zeroconf(interfaces=v4_interfaces or InterfaceChoice.All)
            try:
                zc.register_service(info, allow_name_change=True)
            except BaseException:
                zc.close()
                raise
            self._zeroconf = zc
            self._info = info
            log.info(
                "mDNS: advertising %r on port %d (%s)",
                info.name,
                self.http_port,
                ", ".join(info.parsed_addresses()) or "no address",
            )

    def stop(self) -> None:
        """Send goodbye packets and close zeroconf; safe to call repeatedly or before ``start()``."""
        with self._lock:
            zc, info = self._zeroconf, self._info
            if zc is None:
                return
            self._zeroconf = None
            self._info = None
            try:
                if info is not None:
                    zc.unregister_service(info)
            except Exception:  # still close the sockets; a missed goodbye only delays removal
                log.warning("mDNS: unregistering %r failed", info.name if info else None, exc_info=True)
            finally:
                zc.close()
            log.info("mDNS: advertisement withdrawn")
