"""ConformU's conformance run against the real-transcript firmware preset (issue 39 item 4).

The same reproduction as test_conformu.py (``run_conformance``), with the built-in emulator answering as
the AM5 on firmware 1.8.8 was recorded answering (``am5-1.8.8``, docs/firmware-evidence.md: home reads
``E`` at HA +6 h, ``:GU#`` in the real shape, ``:Te#``/``:Td#`` acknowledged late while slewing, the
measured jog rates), north of the equator and at Sydney, in equatorial and alt-az mode: the server must
come out as clean as on the default preset. A file of its own so CI runs it in a lane of its own (scripts/lanes.py),
beside the default preset's runs: each run mostly waits on emulated time.
"""

from __future__ import annotations

import pytest

from tests.conformance.test_conformu import MODES, run_conformance
from tests.conftest import ServerFactory
from tests.support.sites import NORTH, SYDNEY, Site

#: The firmware presets modelled on recorded real mounts (the default preset runs in test_conformu.py
#: and test_conformu_sites.py).
REAL_PRESETS = ("am5-1.8.8",)


@pytest.mark.timeout(780)  # equatorial: + the SideOfPier write test's 7 emulated minutes through the meridian
@pytest.mark.parametrize("site", [NORTH, SYDNEY], ids=["north", "sydney"])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("preset", REAL_PRESETS)
def test_conformu_conformance_real_firmware(server_factory: ServerFactory, conformu_client_id: None,
                                            preset: str, mode: str, site: Site) -> None:
    """0 errors, 0 issues with the mount answering as the recorded 1.8.8 firmware, north and at Sydney."""
    run_conformance(server_factory, mode, site, preset=preset)
