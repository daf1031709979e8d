"""The telescope tests' fixtures: a server on the fast emulator, its mount, and clients."""

from __future__ import annotations

import pytest

from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import ServerFactory
from tests.telescope.harness import Api, fast_settings


@pytest.fixture
def server(server_factory: ServerFactory) -> AlpacaZwoServer:
    return server_factory(fast_settings())


@pytest.fixture
def url(server: AlpacaZwoServer) -> str:
    return f"http://127.0.0.1:{server.port}"


@pytest.fixture
def model(server: AlpacaZwoServer) -> MountModel:
    emulator = server.emulators[0]
    assert emulator is not None
    return emulator.model


@pytest.fixture
def api(url: str) -> Api:
    """A connected client."""
    return Api(url).connect()


@pytest.fixture
def fresh(url: str) -> Api:
    """A client on a server nobody has connected to yet."""
    return Api(url)


@pytest.fixture(params=["requests", "alpyca"])
def transport_kind(request: pytest.FixtureRequest) -> str:
    return str(request.param)
