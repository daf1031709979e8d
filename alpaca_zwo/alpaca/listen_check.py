"""Can the server listen where its settings say? Asked before ``server.host``/``server.port`` are saved
and again at start, so a setting the machine cannot honour is refused with a reason instead of
making the next start fail.

The test is the operating system's own: bind a socket. An address belongs to this machine exactly
when a socket can bind it (``EADDRNOTAVAIL`` otherwise), and a port is free exactly when a listening
socket can take it (with ``SO_REUSEADDR``, as waitress binds, so a connection in TIME_WAIT does not
count as "in use"). A name is resolved as waitress resolves it and every address it gives must
pass, because waitress listens on all of them.
"""

from __future__ import annotations

import errno
import os
import socket

#: The wildcard addresses: every address of this machine (IPv4, IPv6).
WILDCARDS = ("0.0.0.0", "::")
_HINT = "use 0.0.0.0 (all addresses), :: or an address of this machine"


def _addresses(host: str) -> list[tuple[int, str]]:
    """(family, address) of every address ``host`` names, in resolver order, without repeats."""
    infos = socket.getaddrinfo(host, None, socket.AF_UNSPEC, socket.SOCK_STREAM, socket.IPPROTO_TCP,
                               socket.AI_PASSIVE)
    found: list[tuple[int, str]] = []
    for family, _, _, _, sockaddr in infos:
        if family in (socket.AF_INET, socket.AF_INET6) and (family, str(sockaddr[0])) not in found:
            found.append((family, str(sockaddr[0])))
    return found


def _bind(family: int, address: str, port: int) -> OSError | None:
    """None if a listening socket can take ``address:port`` now, else the error that stopped it."""
    try:
        with socket.socket(family, socket.SOCK_STREAM) as sock:
            if os.name == "posix":
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            # No IPV6_V6ONLY: waitress leaves the system default, so "::" meets IPv4 listeners too.
            sock.bind((address, port))
            sock.listen(1)
    except OSError as exc:
        return exc
    return None


def host_problem(host: str) -> str | None:
    """Why the server could not listen on ``host`` (None: it can)."""
    if not host or any(ord(c) < 0x21 or ord(c) == 0x7F for c in host):
        return f"server.host {host!r} is empty or holds a space or control character: {_HINT}"
    if len(host) > 253:
        return f"server.host is {len(host)} characters long, longer than any host name: {_HINT}"
    try:
        addresses = _addresses(host)
    except (OSError, UnicodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        return f"server.host {host!r} does not resolve ({reason}): {_HINT}"
    if not addresses:
        return f"server.host {host!r} names no IPv4 or IPv6 address: {_HINT}"
    for family, address in addresses:
        error = _bind(family, address, 0)
        if error is not None:
            shown = "" if address == host else f" (it names {address})"
            if error.errno == errno.EADDRNOTAVAIL:
                return f"server.host {host!r} is not an address of this machine{shown}: {_HINT}"
            return f"server.host {host!r}{shown} cannot be listened on ({error.strerror or error}): {_HINT}"
    return None


def port_problem(host: str, port: int, current_port: int | None = None) -> str | None:
    """Why the server could not listen on ``host:port`` (None: it can, or it is the port in use now).

    Port 0 (any free port) always can; ``current_port`` is the one this server holds, which a
    restart frees. ``host`` must already pass :func:`host_problem`.
    """
    if port == 0 or port == current_port:
        return None
    for family, address in _addresses(host):
        error = _bind(family, address, port)
        if error is None:
            continue
        if error.errno == errno.EADDRINUSE:
            return (f"server.port {port} is in use on {address} (another program, or another alpaca-zwo, "
                    "listens there): pick a free port, e.g. 11111")
        if error.errno == errno.EACCES:
            return (f"server.port {port} needs administrator rights on this machine (ports below 1024): "
                    "use 1024 or above")
        return f"server.port {port} cannot be listened on at {address}: {error.strerror or error}"
    return None


def port_in_use(host: str, port: int) -> bool:
    """Another listener holds ``port`` on an address ``host`` names (``host`` must pass :func:`host_problem`)."""
    if port == 0:
        return False
    errors = (_bind(family, address, port) for family, address in _addresses(host))
    return any(error is not None and error.errno == errno.EADDRINUSE for error in errors)


def listen_problem(host: str, port: int, current_port: int | None = None) -> str | None:
    """The first reason ``host:port`` cannot be listened on, or None."""
    return host_problem(host) or port_problem(host, port, current_port)
