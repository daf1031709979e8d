"""Shared fixtures: a real alpaca-zwo server (waitress on a free loopback port) on the real emulator."""

from __future__ import annotations

import dataclasses
import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from alpaca_zwo.config.settings import EmulatorSettings, ServerSettings, Settings, SiteSettings, assign_unique_ids
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.server import AlpacaZwoServer, Overrides


def make_settings(**sections: Any) -> Settings:
    """Test settings: loopback only, no discovery, unpaced emulator; override any section."""
    base = Settings(
        server=ServerSettings(host="127.0.0.1", port=0, discovery_port=0),
        site=SiteSettings(latitude=51.4769, longitude=-0.0005, elevation=46.0),
        emulator=EmulatorSettings(speed=1.0, baud=0),
    )
    return assign_unique_ids(dataclasses.replace(base, **sections))


ServerFactory = Callable[..., AlpacaZwoServer]


@pytest.fixture
def server_factory(tmp_path: Path) -> Iterator[ServerFactory]:
    """Start real servers (each on its own free port and config file); all are stopped afterwards."""
    started: list[AlpacaZwoServer] = []

    def start(settings: Settings | None = None, overrides: Overrides | None = None, *, setup: bool = True,
              config_name: str = "config.toml") -> AlpacaZwoServer:
        from alpaca_zwo.web import setup_routes

        store = SettingsStore(settings or make_settings(), tmp_path / config_name)
        server = AlpacaZwoServer(store, overrides, extra_routes_factory=setup_routes if setup else None)
        started.append(server)
        server.start()
        return server

    yield start
    for server in reversed(started):
        server.stop()


@pytest.fixture
def live_server(server_factory: ServerFactory) -> AlpacaZwoServer:
    """One running server on the built-in emulator, not yet connected by any client."""
    return server_factory()


@pytest.fixture
def base_url(live_server: AlpacaZwoServer) -> str:
    return f"http://127.0.0.1:{live_server.port}"


@pytest.fixture
def listener() -> Iterator[int]:
    """A port another program listens on (127.0.0.1): for tests of a port already in use."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(1)
        yield sock.getsockname()[1]
