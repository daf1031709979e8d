"""Fixtures for the emulator tests: a real EmulatorServer on a free loopback port, a ManualClock
that only moves when a test says so, and clients over real TCP sockets (see ``emuclient``)."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from alpaca_zwo.emulator import EmulatorServer, FirmwareVariant, ManualClock, MountModel
from tests.emulator.emuclient import START_UTC, MountClient, initialize


@pytest.fixture
def clock() -> ManualClock:
    return ManualClock(START_UTC)


@pytest.fixture
def firmware() -> FirmwareVariant:
    """Override in a test module (or parametrize) to run against another firmware variant."""
    return FirmwareVariant()


@pytest.fixture
def model(clock: ManualClock, firmware: FirmwareVariant) -> MountModel:
    return MountModel(clock, firmware)


@pytest.fixture
def emu(model: MountModel) -> Iterator[EmulatorServer]:
    """An unpaced emulator server on a free loopback port."""
    server = EmulatorServer(model, host="127.0.0.1", port=0, baud=0).start()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def connect(emu: EmulatorServer) -> Iterator[Callable[[], MountClient]]:
    clients: list[MountClient] = []

    def make() -> MountClient:
        client = MountClient(emu.port, compile_time=emu.model.firmware.compile_time)
        clients.append(client)
        return client

    yield make
    for client in clients:
        client.close()


@pytest.fixture
def mount(connect: Callable[[], MountClient]) -> MountClient:
    """A client on a mount in its power-up state."""
    return connect()


@pytest.fixture
def ready(mount: MountClient, clock: ManualClock) -> MountClient:
    """A client on a mount whose date, time (UTC) and site have been set."""
    initialize(mount, clock)
    return mount
