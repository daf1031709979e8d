"""ConformU's conformance run at Sydney and on the equator (issue 30), in equatorial and alt-az mode.

The same reproduction as test_conformu.py (``run_conformance``), with the site written through Alpaca
as a N.I.N.A. profile does. A file of its own so CI runs it in a lane of its own, beside the northern
runs (scripts/lanes.py): each ConformU run mostly waits on emulated time (3x, as in test_conformu.py:
its pulse-guide and rate-offset checks are judged to fractions of an arcsecond), so two side by side
cost the suite's wall time little CPU and halve the lane.
"""

from __future__ import annotations

import pytest

from tests.conformance.test_conformu import MODES, run_conformance
from tests.conftest import ServerFactory
from tests.support.sites import EQUATOR, SYDNEY, Site


@pytest.mark.timeout(780)  # equatorial at Sydney: + the SideOfPier write test's 7 emulated minutes
@pytest.mark.parametrize("site", [SYDNEY, EQUATOR], ids=["sydney", "equator"])
@pytest.mark.parametrize("mode", MODES)
def test_conformu_conformance_where_the_users_are(server_factory: ServerFactory, conformu_client_id: None,
                                                  mode: str, site: Site) -> None:
    """0 errors, 0 issues at Sydney (-33.8688°, 151.2093°) and on the equator (0°, 36.8°)."""
    run_conformance(server_factory, mode, site)
