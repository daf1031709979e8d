"""This machine's LAN addresses and networks: the start banner's page URLs, the bridges' "local" networks.

A server listening on 0.0.0.0 or :: is reached from a phone by one of the machine's own addresses,
which the person at the mount does not know; printing only 127.0.0.1 sends them hunting. The
addresses are read locally and nothing is sent on any network: on Linux from the kernel (one
``SIOCGIFADDR`` ioctl per interface for IPv4, ``/proc/net/if_inet6`` for IPv6), everywhere from
the resolver's answer for this host's own name (on Windows and macOS that lists the interfaces'
addresses). No new dependency (psutil/netifaces) and no "connect a UDP socket to 8.8.8.8" trick.
Loopback, link-local (169.254/16, fe80::/10: a browser cannot use them without a zone) and
unspecified addresses are left out.

The networks of this machine's own interfaces (address and prefix) are what the bridges'
``allowed_networks`` entry ``"local"`` admits besides loopback: a laptop on the same LAN works, a
routed or VPN network needs its own line. They are read as locally: on Linux from the kernel's
address table over netlink (every address, secondaries included; a message to the kernel, not to
any network), on macOS and the BSDs from ``ifconfig``'s output; elsewhere (Windows) the prefix is not
readable without a new dependency, so each of this machine's addresses counts with a /24 (IPv4) or
/64 (IPv6) around it, the usual home-LAN sizes (an assumption the setup page shows, so a wider LAN can
be added as a line).
"""

from __future__ import annotations

import contextlib
import ipaddress
import re
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

__all__ = ["LOOPBACK_NETWORKS", "interface_networks", "lan_addresses", "local_networks", "mdns_name",
           "page_urls", "parse_ifconfig"]

Network = ipaddress.IPv4Network | ipaddress.IPv6Network

#: Loopback, always part of "local".
LOOPBACK_NETWORKS: tuple[Network, ...] = (ipaddress.ip_network("127.0.0.0/8"), ipaddress.ip_network("::1/128"))
#: How long a reading of the interfaces is reused (a DHCP lease or a new WiFi changes them rarely).
NETWORKS_TTL_S = 10.0

_SIOCGIFADDR = 0x8915  # Linux <linux/sockios.h>
_IF_INET6 = Path("/proc/net/if_inet6")
_GLOBAL_SCOPE = 0x00
_UNUSABLE_FLAGS = 0x40 | 0x08  # IFA_F_TENTATIVE | IFA_F_DADFAILED


def _usable(address: str) -> bool:
    try:
        ip = ipaddress.ip_address(address.split("%", 1)[0])
    except ValueError:
        return False
    return not (ip.is_loopback or ip.is_link_local or ip.is_unspecified or ip.is_multicast)


def _linux_ipv4() -> list[str]:
    """The primary IPv4 address of every interface (the kernel's own answer, no traffic)."""
    import fcntl

    found: list[str] = []
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for _, name in socket.if_nameindex():
            request = struct.pack("256s", name.encode()[:15])
            try:
                reply = fcntl.ioctl(sock.fileno(), _SIOCGIFADDR, request)
            except OSError:  # no IPv4 address on this interface
                continue
            found.append(socket.inet_ntoa(reply[20:24]))
    return found


def _linux_ipv6() -> list[str]:
    """Global-scope IPv6 addresses that finished duplicate detection, from ``/proc/net/if_inet6``."""
    found: list[str] = []
    for line in _IF_INET6.read_text().splitlines():
        fields = line.split()
        if len(fields) < 6 or int(fields[3], 16) != _GLOBAL_SCOPE or int(fields[4], 16) & _UNUSABLE_FLAGS:
            continue
        found.append(str(ipaddress.IPv6Address(bytes.fromhex(fields[0]))))
    return found


def _resolver() -> list[str]:
    """What this host's name resolves to (Windows and macOS list their interfaces' addresses here)."""
    with contextlib.suppress(OSError, UnicodeError):
        infos = socket.getaddrinfo(socket.gethostname(), None, socket.AF_UNSPEC, socket.SOCK_STREAM)
        return [str(info[4][0]) for info in infos if info[0] in (socket.AF_INET, socket.AF_INET6)]
    return []


def lan_addresses(ipv6: bool = True) -> list[str]:
    """This machine's addresses another host on the LAN could use: IPv4 first, without repeats."""
    found: list[str] = []
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, ValueError, ImportError):
            found += _linux_ipv4()
        with contextlib.suppress(OSError, ValueError):
            found += _linux_ipv6()
    found += _resolver()
    unique = list(dict.fromkeys(a for a in found if _usable(a)))
    if not ipv6:
        unique = [a for a in unique if ":" not in a]
    return sorted(unique, key=lambda a: ":" in a)  # stable: IPv4 before IPv6, each in found order


def mdns_name() -> str | None:
    """``<short hostname>.local``, the name phones and laptops resolve by mDNS (None for a nameless host)."""
    short = socket.gethostname().split(".", 1)[0]
    return f"{short}.local" if short and short != "localhost" else None


def page_urls(host: str, port: int, path: str = "/setup") -> list[str]:
    """The URLs of ``path`` another device may open: one per LAN address, then ``<host>.local``.

    ``host`` is where the server listens; a wildcard (``0.0.0.0``: IPv4; ``::``/empty: IPv6 and,
    dual-stack as Linux and macOS make it by default, IPv4 too) lists this machine's addresses,
    anything else is its own single URL.
    """
    if host not in ("0.0.0.0", "::", ""):
        shown = f"[{host}]" if ":" in host else host
        return [f"http://{shown}:{port}{path}"]
    addresses = lan_addresses(ipv6=host != "0.0.0.0")
    if host != "0.0.0.0" and sys.platform == "win32":  # Windows' "::" socket is IPv6-only (IPV6_V6ONLY on)
        addresses = [a for a in addresses if ":" in a]
    urls = [f"http://{f'[{a}]' if ':' in a else a}:{port}{path}" for a in addresses]
    name = mdns_name()
    if name:
        urls.append(f"http://{name}:{port}{path}")
    return urls


# --- the networks of this machine's own interfaces ----------------------------------------------------

_NETLINK_ROUTE = 0
_RTM_NEWADDR, _RTM_GETADDR = 20, 22
_NLMSG_ERROR, _NLMSG_DONE = 2, 3
_NLM_F_REQUEST_DUMP = 0x1 | 0x300
_IFA_ADDRESS, _IFA_LOCAL = 1, 2
_NLMSG = struct.Struct("=IHHII")  # length, type, flags, sequence, port id
_IFADDRMSG = struct.Struct("=BBBBI")  # family, prefix length, flags, scope, interface index
_RTATTR = struct.Struct("=HH")  # length, type


def _aligned(length: int) -> int:
    return (length + 3) & ~3


def _address_attributes(message: bytes, family: int) -> tuple[str | None, str | None]:
    """IFA_ADDRESS and IFA_LOCAL of one RTM_NEWADDR message, as text."""
    found: dict[int, str] = {}
    offset = _NLMSG.size + _IFADDRMSG.size
    while offset + _RTATTR.size <= len(message):
        length, kind = _RTATTR.unpack_from(message, offset)
        if length < _RTATTR.size:
            break
        if kind in (_IFA_ADDRESS, _IFA_LOCAL):
            found[kind] = socket.inet_ntop(family, message[offset + _RTATTR.size: offset + length])
        offset += _aligned(length)
    return found.get(_IFA_ADDRESS), found.get(_IFA_LOCAL)


def _netlink_networks() -> list[Network]:
    """Every address of every interface with its prefix, from the kernel (RTM_GETADDR dump)."""
    found: list[Network] = []
    with socket.socket(socket.AF_NETLINK, socket.SOCK_RAW, _NETLINK_ROUTE) as sock:  # type: ignore[attr-defined,unused-ignore]
        sock.settimeout(2.0)
        sock.bind((0, 0))
        header_size = _NLMSG.size + _IFADDRMSG.size
        sock.send(_NLMSG.pack(header_size, _RTM_GETADDR, _NLM_F_REQUEST_DUMP, 1, 0)
                  + _IFADDRMSG.pack(socket.AF_UNSPEC, 0, 0, 0, 0))
        while True:
            data = sock.recv(1 << 16)
            offset = 0
            while offset + _NLMSG.size <= len(data):
                length, kind = _NLMSG.unpack_from(data, offset)[:2]
                if kind == _NLMSG_DONE or length < _NLMSG.size:
                    return found
                if kind == _NLMSG_ERROR:
                    raise OSError("netlink refused the address dump")
                message = data[offset: offset + length]
                if kind == _RTM_NEWADDR and len(message) >= header_size:
                    family, prefix = _IFADDRMSG.unpack_from(message, _NLMSG.size)[:2]
                    if family in (socket.AF_INET, socket.AF_INET6):
                        # IFA_ADDRESS is the on-link side (the peer's, on a point-to-point link).
                        address, local = _address_attributes(message, family)
                        if address or local:
                            found.append(ipaddress.ip_network(f"{address or local}/{prefix}", strict=False))
                offset += _aligned(length)
            if not data:
                return found


_IFCONFIG_INET = re.compile(r"\binet\s+(\d+\.\d+\.\d+\.\d+)\s.*?\bnetmask\s+(0x[0-9a-fA-F]{8}|\d+\.\d+\.\d+\.\d+)")
_IFCONFIG_INET6 = re.compile(r"\binet6\s+([0-9a-fA-F:.]+)(?:%\S+)?\s.*?\bprefixlen\s+(\d+)")


def parse_ifconfig(text: str) -> list[Network]:
    """The networks in ``ifconfig -a`` output as macOS and the BSDs print it.

    ``inet 192.168.1.23 netmask 0xffffff00 broadcast ...`` and ``inet6 fe80::1%en0 prefixlen 64 ...``.
    """
    found: list[Network] = []
    for line in text.splitlines():
        with contextlib.suppress(ValueError):
            if match := _IFCONFIG_INET.search(line):
                mask = match[2]
                if mask.startswith("0x"):
                    mask = str(ipaddress.IPv4Address(int(mask, 16)))
                found.append(ipaddress.ip_network(f"{match[1]}/{mask}", strict=False))
            elif match := _IFCONFIG_INET6.search(line):
                found.append(ipaddress.ip_network(f"{match[1]}/{match[2]}", strict=False))
    return found


def _ifconfig_networks() -> list[Network]:
    for path in ("/sbin/ifconfig", "/usr/sbin/ifconfig"):
        if Path(path).exists():
            done = subprocess.run([path, "-a"], capture_output=True, text=True, timeout=5, check=False)
            return parse_ifconfig(done.stdout)
    return []


def _assumed_networks() -> list[Network]:
    """This machine's addresses, each with the usual home-LAN prefix around it (/24, /64)."""
    found: list[Network] = []
    for address in _resolver():
        with contextlib.suppress(ValueError):
            ip = ipaddress.ip_address(address.split("%", 1)[0])
            found.append(ipaddress.ip_network(f"{ip}/{24 if ip.version == 4 else 64}", strict=False))
    return found


def _read_interface_networks() -> list[Network]:
    readers = []
    if sys.platform.startswith("linux"):
        readers.append(_netlink_networks)
    elif sys.platform == "darwin" or "bsd" in sys.platform:
        readers.append(_ifconfig_networks)
    readers.append(_assumed_networks)
    for reader in readers:
        with contextlib.suppress(OSError, ValueError, subprocess.SubprocessError):
            found = reader()
            if found:
                return found
    return []


_networks_lock = threading.Lock()
_networks_read: tuple[float, tuple[Network, ...]] | None = None


def interface_networks() -> tuple[Network, ...]:
    """The networks of this machine's interfaces (no /0, loopback left to :data:`LOOPBACK_NETWORKS`).

    Read again when the last reading is older than :data:`NETWORKS_TTL_S`: a bridge asks on every
    connection, and a laptop that just joined the LAN must not wait for a restart.
    """
    global _networks_read
    with _networks_lock:
        now = time.monotonic()
        if _networks_read is not None and now - _networks_read[0] < NETWORKS_TTL_S:
            return _networks_read[1]
        networks = tuple(dict.fromkeys(n for n in _read_interface_networks()
                                       if n.prefixlen > 0 and not n.is_loopback))
        _networks_read = (now, networks)
        return networks


def local_networks() -> tuple[Network, ...]:
    """What ``"local"`` in a bridge's ``allowed_networks`` means now: loopback and the interfaces' networks."""
    return LOOPBACK_NETWORKS + interface_networks()
