"""The sites the motion, guiding, flip, park, Alt/Az, page and conformance tests run at (issue 30).

Where the users are: a northern site (Greenwich, the default of ``tests.conftest.make_settings``),
Sydney and the equator, with ±70° where a check is cheap. A test takes the ``site`` fixture (or
``pytest.mark.parametrize("site", SITES, ids=...)``) and mirrors its declinations toward the elevated
pole with ``Site.dec``, so one test states one rule for every site instead of being copied.

The extra sites may run on a faster emulator clock (``Site.speed``) where a test judges where the
mount ends up rather than timing, to keep the CI budget (scripts/lanes.py): the northern site keeps
the speed the test was written for.
"""

from __future__ import annotations

from dataclasses import dataclass

from alpaca_zwo.config.settings import SiteSettings


@dataclass(frozen=True)
class Site:
    name: str
    latitude: float
    longitude: float  # east positive
    elevation: float = 50.0

    @property
    def pole(self) -> float:
        """+1 where the north celestial pole is up (the equator counts as north, as on the mount)."""
        return 1.0 if self.latitude >= 0.0 else -1.0

    def dec(self, toward_pole: float) -> float:
        """The declination ``toward_pole`` degrees from the celestial equator toward the elevated pole."""
        return self.pole * toward_pole

    def settings(self) -> SiteSettings:
        return SiteSettings(latitude=self.latitude, longitude=self.longitude, elevation=self.elevation)

    def speed(self, base: float, extra: float = 2.0) -> float:
        """``base`` at the northern site the test was written for, ``base * extra`` elsewhere."""
        return base if self is NORTH else base * extra


NORTH = Site("north", 51.4769, -0.0005, 46.0)
SYDNEY = Site("sydney", -33.8688, 151.2093, 58.0)
EQUATOR = Site("equator", 0.0, 36.8, 1795.0)
NORTH70 = Site("north70", 70.0, 25.0)
SOUTH70 = Site("south70", -70.0, -60.0)

SITES = (NORTH, SYDNEY, EQUATOR)
SITE_IDS = tuple(site.name for site in SITES)
#: The three sites and the two far ones, for the cheap checks.
ALL_SITES = (*SITES, NORTH70, SOUTH70)
ALL_SITE_IDS = tuple(site.name for site in ALL_SITES)
