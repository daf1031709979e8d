"""The sky objects the setup page finds and draws: the object catalogue, its data and its search.

``objects`` (the search over the IAU-named stars of ``star_names.csv`` and the chart's stars of
``sky_data.json`` by HIP and designation, PyEphem's planets, OpenNGC, typed coordinates; which match
Enter may take; the topocentric apparent place; the site's time zone), with its parts ``coordinates``
(typed coordinates and their ambiguity), ``naming`` (the ``SkyObject`` record, name keys: Greek
letters, the genitives of ``constellations.csv``) and ``deepsky`` (OpenNGC via pyongc's database,
with ``dso_names.csv``'s common names; the chart's deep-sky list). docs/objects.md.

Pure: no server state, no I/O but its own data files. It brings PyEphem and OpenNGC, so nothing imports
its modules at server start: the page's routes (``web/goto.py``, ``web/skyview.py``) import them on their
first request. This ``__init__`` imports nothing, so naming the package costs nothing.

May import ``alpaca_zwo.sky`` and itself, nothing else of the package (a test checks).
"""

from __future__ import annotations

from importlib import resources


def data_text(name: str) -> str:
    """One of the catalogue's data files (``sky_data.json``, ``star_names.csv`` ...), as text: found
    through the package, so an installed wheel reads it as a checkout does."""
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")
