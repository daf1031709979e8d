"""This machine's LAN addresses, for the start banner's "open the page at ..." lines.

A server listening on 0.0.0.0 or :: is reached from a phone by one of the machine's own addresses,
which the person at the mount does not know; printing only 127.0.0.1 sends them hunting. The
addresses are read locally and nothing is sent on any network: on Linux from the kernel (one
``SIOCGIFADDR`` ioctl per interface for IPv4, ``/proc/net/if_inet6`` for IPv6), everywhere from
the resolver's answer for this host's own name (on Windows and macOS that lists the interfaces'
addresses). No new dependency (psutil/netifaces) and no "connect a UDP socket to 8.8.8.8" trick.
Loopback, link-local (169.254/16, fe80::/10: a browser cannot use them without a zone) and
unspecified addresses are left out.
"""

from __future__ import annotations

import contextlib
import ipaddress
import socket
import struct
import sys
from pathlib import Path

__all__ = ["lan_addresses", "mdns_name", "page_urls"]

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
