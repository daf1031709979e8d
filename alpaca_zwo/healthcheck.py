"""``python -m alpaca_zwo.healthcheck``: exit 0 when the server in this container answers.

The container's HEALTHCHECK runs this. It asks ``/management/apiversions`` on the port the server
was really started with: it reads the server's own command line (``/proc/1/cmdline``, the
container's main process) for ``--port``/``--host``/``--config``, then the config file's
``[server]`` table, then the default 11111. So ``docker run ... alpaca-zwo --port 11112`` stays
healthy, which a probe of a hard-coded port would not.
"""

from __future__ import annotations

import sys
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["main", "server_address"]

DEFAULT_PORT = 11111
_WILDCARDS = {"0.0.0.0": "127.0.0.1", "::": "::1", "": "127.0.0.1"}


def _option(words: list[str], name: str) -> str | None:
    """The value of ``--name VALUE`` or ``--name=VALUE`` (the last one wins, as in argparse)."""
    value = None
    for index, word in enumerate(words):
        if word == name and index + 1 < len(words):
            value = words[index + 1]
        elif word.startswith(name + "="):
            value = word.split("=", 1)[1]
    return value


def server_address(pid: int = 1) -> tuple[str, int]:
    """(host to ask, port) of the server running as ``pid``."""
    words = [w.decode(errors="replace") for w in Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0") if w]
    server: dict[str, Any] = {}
    config = _option(words, "--config")
    if config:
        try:
            server = tomllib.loads(Path(config).read_text(encoding="utf-8")).get("server", {})
        except (OSError, ValueError):
            server = {}
    port = _option(words, "--port") or server.get("port", DEFAULT_PORT)
    host = _option(words, "--host") or server.get("host", "0.0.0.0")
    return _WILDCARDS.get(str(host), str(host)), int(port)


def main(argv: list[str] | None = None) -> int:
    pid = int(argv[0]) if argv else 1
    try:
        host, port = server_address(pid)
    except (OSError, ValueError) as exc:
        print(f"healthcheck: cannot read the server's command line: {exc}")
        return 1
    netloc = f"[{host}]:{port}" if ":" in host else f"{host}:{port}"
    try:
        with urllib.request.urlopen(f"http://{netloc}/management/apiversions", timeout=4) as reply:
            ok = reply.status == 200
    except urllib.error.HTTPError as exc:
        ok = exc.code == 401  # basic auth is on: the server is there and answering
    except OSError as exc:
        print(f"healthcheck: no answer on {netloc}: {exc}")
        return 1
    print(f"healthcheck: {netloc} {'answers' if ok else 'answered with an error'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
