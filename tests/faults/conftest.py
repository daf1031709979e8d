"""The fault rig: a real server on the in-process emulator, a connected client and a wire recorder."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest

from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.emulator.faults import Faults
from alpaca_zwo.mount.operations import Mount
from alpaca_zwo.server import AlpacaZwoServer, Overrides
from alpaca_zwo.telescope.device import Telescope
from alpaca_zwo.zwo.link import Link
from tests.conftest import ServerFactory, make_settings
from tests.faults.harness import MountRecorder, TraceAudit
from tests.support import AlpacaClient, CallLog, wait_until

#: The ClientID the scenario's main client (an imaging program) uses.
MAIN_ID = 4242


@dataclass
class Rig:
    """One running server, its emulated mount and the instruments around them."""

    server: AlpacaZwoServer
    emulator: EmulatorServer
    recorder: MountRecorder
    log: CallLog = field(default_factory=CallLog)
    clients: list[AlpacaClient] = field(default_factory=list)

    @property
    def telescope(self) -> Telescope:
        return self.server.telescopes[0]

    @property
    def mount(self) -> Mount:
        return self.telescope.mount

    @property
    def link(self) -> Link:
        return self.mount.link

    @property
    def model(self) -> MountModel:
        return self.emulator.model

    @property
    def faults(self) -> Faults:
        return self.model.faults

    @property
    def port(self) -> int:
        return self.server.port

    def truth(self) -> datetime:
        """UTC in the emulated universe (the server's clock too: it measures mount time on it)."""
        return self.model.clock.now()

    def client(self, client_id: int) -> AlpacaClient:
        client = AlpacaClient(self.port, client_id, self.log)
        self.clients.append(client)
        return client

    def audit(self) -> TraceAudit:
        audit = TraceAudit()
        audit.feed(self.link.trace(), self.recorder)
        return audit

    def snapshot(self) -> dict[str, Any]:
        return self.model.snapshot()


RigFactory = Callable[..., Rig]


@pytest.fixture
def rig_factory(server_factory: ServerFactory, tmp_path: Path) -> Iterator[RigFactory]:
    """Start a server with ``make_settings(**sections)``, record its wire and connect the main client."""

    def start(*, connect: bool = True, usb: bool = False, start_utc: datetime | None = None,
              **sections: Any) -> Rig:
        """``usb=True``: the mount on a pseudo-terminal paced at 9600 baud, opened through a stable
        symlink like a udev name, instead of the built-in emulator's TCP port (its WiFi). ``start_utc``:
        a mount on its own TCP port whose universe starts then, in real time, its clock set (a satellite's
        pass from shipped elements; give ``time=TimeSettings(source="mount")`` so the server takes it)."""
        overrides = None
        external = None
        if start_utc is not None:
            model = MountModel(ScaledClock(1.0, start_utc=start_utc))
            model.initialize()  # its clock set, as by the hand controller that last ran it
            external = EmulatorServer(model, host="127.0.0.1", port=0, baud=0).start()
            externals.append(external)
            overrides = Overrides(device_url=f"socket://127.0.0.1:{external.port}")
        if usb:
            external = EmulatorServer(MountModel(ScaledClock()), port=0, baud=9600, pty=True, tcp=False,
                                      pty_link=str(tmp_path / "ttyACM-am5")).start()
            externals.append(external)
            overrides = Overrides(device_url=str(tmp_path / "ttyACM-am5"))
        server = server_factory(make_settings(**sections), overrides)
        emulator = external or server.emulators[0].server  # type: ignore[union-attr]
        rig = Rig(server, emulator, MountRecorder(emulator))
        rigs.append(rig)
        if connect:
            main = rig.client(MAIN_ID)
            main.command("connected", Connected="true")
            wait_until(lambda: rig.mount.state.position_time is not None, 10, "a first position")
        return rig

    rigs: list[Rig] = []
    externals: list[EmulatorServer] = []
    yield start
    for rig in rigs:
        for client in rig.clients:
            client.close()
        rig.recorder.uninstall()
        rig.server.stop()  # before its external mount goes away, so shutdown can still reach it
    for external in externals:
        external.stop()


@pytest.fixture
def rig(rig_factory: RigFactory) -> Rig:
    return rig_factory()
