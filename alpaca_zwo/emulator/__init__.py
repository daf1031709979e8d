"""A physically faithful emulator of ZWO AM3/AM5/AM5N/AM7 mounts.

``MountModel`` is the mount (two axes, its own clock and site, tracking, GOTO, guiding, limits,
firmware variants); ``ModelResponder`` speaks its wire protocol (``zwo/dispatch.py``'s table, the
model as its backend); ``EmulatorServer`` serves it over TCP and a pseudo-terminal with baud-rate
pacing; ``Faults`` makes the line misbehave on demand.

    model = MountModel(ManualClock(), FirmwareVariant(home_flag="never"))
    with EmulatorServer(model, port=0, baud=0) as server:
        ...  # connect to 127.0.0.1:server.port

May import ``zwo`` (protocol, wire values, request framer, firmware; never the link) and ``sky`` only.
"""

from __future__ import annotations

from ..zwo.firmware import PRESETS, FirmwareVariant, preset
from .clock import ManualClock, ScaledClock
from .control import ControlServer
from .faults import Faults
from .model import MountModel
from .responder import ModelResponder
from .server import EmulatorServer

__all__ = [
    "PRESETS",
    "ControlServer",
    "EmulatorServer",
    "Faults",
    "FirmwareVariant",
    "ManualClock",
    "ModelResponder",
    "MountModel",
    "ScaledClock",
    "preset",
]
