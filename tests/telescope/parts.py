"""A Telescope part's collaborators, real: the emulator on a loopback port, a Link and Mount to it, the
settings store on a file, a motion supervisor. The part under test is built on them by the test itself,
as the Telescope builds it, so each part is tested alone with what it really talks to.
"""

from __future__ import annotations

import dataclasses
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from alpaca_zwo import sky
from alpaca_zwo.clients import ClientRegistry
from alpaca_zwo.config.settings import Settings
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.motion import MotionSupervisor
from alpaca_zwo.mount.operations import Mount
from alpaca_zwo.telescope.connection import Connection
from alpaca_zwo.telescope.stored_settings import StoredSettings
from alpaca_zwo.zwo.link import Link
from tests.conftest import make_settings

#: Emulated seconds per real second: slews end quickly, and the mount's clock is the emulator's.
RIG_SPEED = 10.0


@dataclass
class Rig:
    """The collaborators, as ``server.py`` wires them for one device (the mount not yet connected)."""

    model: MountModel
    mount: Mount
    store: SettingsStore
    motion: MotionSupervisor
    registry: ClientRegistry

    @property
    def settings(self) -> Settings:
        return self.store.settings

    def connection(self, linger_s: float = 60.0, link_grace_s: float = 30.0) -> Connection:
        """A Connection as the Telescope builds one: the parts' ``require_connected`` is its."""
        return Connection(mount=self.mount, motion=self.motion, stored=self.stored_settings(), linger_s=linger_s,
                          link_grace_s=link_grace_s)

    def stored_settings(self) -> StoredSettings:
        """The mount's stored settings' owner, as the Telescope builds it."""
        return StoredSettings(mount=self.mount, store=self.store)


def closed_port() -> int:
    """A loopback port nothing listens on: a mount that is switched off (connect refused at once)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


@contextmanager
def parts_rig(tmp_path: Path, *, url: str | None = None, settings: Settings | None = None,
              clock: ScaledClock | None = None, **model_options: Any) -> Iterator[Rig]:
    """The collaborators of a Telescope part on the real emulator (``url``: another mount instead).

    ``model_options`` go to :class:`MountModel` (``firmware=``, ``mode=``); ``clock`` is the emulated
    universe's (default: ``RIG_SPEED`` times real time, from now); everything is stopped after.
    """
    clock = clock or ScaledClock(RIG_SPEED)
    model = MountModel(clock, **model_options)
    emulator = EmulatorServer(model, host="127.0.0.1", port=0, baud=0).start()
    store = SettingsStore(settings or make_settings(), tmp_path / "config.toml")
    link = Link(url or f"socket://127.0.0.1:{emulator.port}", timeout=1.0, reconnect_delays=(0.1, 0.2, 0.5))
    mount = Mount(link, lambda: (store.settings.site.latitude, store.settings.site.longitude),
                  clock=model.clock.now, monotonic=model.clock.seconds, clock_rate=clock.speed)
    registry = ClientRegistry()
    motion = MotionSupervisor(mount, lambda: store.settings,
                              lambda now=None: sky.local_sidereal_time(now or mount.time.now(),
                                                                       store.settings.site.longitude),
                              registry, name="motion-parts-rig")
    try:
        yield Rig(model, mount, store, motion, registry)
    finally:
        motion.close()
        if mount.running:
            mount.disconnect()
        emulator.stop()


def with_limits(**limits: Any) -> Settings:
    """Test settings with some ``limits`` fields changed."""
    base = make_settings()
    return dataclasses.replace(base, limits=dataclasses.replace(base.limits, **limits))
