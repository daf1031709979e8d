"""The setup and status web page: ``/setup``, the per-device setup URL, its assets and a JSON API.

One module per job: ``files`` (the page and its static files), ``status`` (the status feed),
``settings`` (the settings API, server settings included), ``commands`` (the controls), ``trace``
(the serial trace), ``logview`` (the log view), ``guide`` (the user guide at ``/docs``), ``observatory``
(the safety interlock's state and finding its devices), ``pointing`` (the pointing model), ``satellites``
(kept TLE sets, their passes, following one), ``survey`` (the owner's survey), ``http`` (security and JSON
plumbing) and ``context`` (what the routes share). The package talks to the rest of the server only through
:mod:`alpaca_zwo.facade`; ``goto`` and ``skyview`` read the object catalogue (:mod:`alpaca_zwo.catalogue`,
pure data and search) on their first request.

May import ``alpaca_zwo.facade``, ``alpaca_zwo.catalogue`` and itself, nothing else of the package (a test checks).
"""

from __future__ import annotations

import logging
from pathlib import Path

from ..facade import FacadeProvider
from .commands import ActionResource
from .context import WebContext
from .files import DeviceSetupPage, RootRedirect, SetupPage, StaticFiles, static_dir
from .goto import GotoResource, GotoVerdict, ObjectDetails, ObjectSearch, SyncResource
from .guide import guide_routes
from .http import CSRF_HEADER, check_same_origin
from .logview import LogBuffer, LogResource, LogText, log_buffer
from .observatory import SafetyDiscoverResource, SafetyResource, SafetyTestResource
from .pointing import PointingModelResource
from .satellites import FollowResource, SatellitesResource
from .settings import ServerResource, SettingsResource
from .skyview import SkyResource
from .status import StatusResource
from .survey import SurveyResource, SurveyText
from .trace import TraceResource, TraceText

log = logging.getLogger(__name__)


def setup_routes(server: FacadeProvider, static_root: Path | None = None) -> list[tuple[str, object]]:
    """The ``(uri_template, resource)`` pairs of the setup page, mounted by the server on its app."""
    files = StaticFiles(static_root or static_dir())
    if files.find("index.html") is None:
        log.error("setup page files not found in %s: /setup will answer 404", files.root)
    facade = server.facade
    web = WebContext(facade, log_buffer())
    return [
        ("/", RootRedirect()),  # not any_host: an open "/" would open every path (HostCheck prefixes)
        ("/index.html", RootRedirect()),
        ("/setup", SetupPage(files)),
        ("/setup/v1/{device_type}/{device_number}/{page}", DeviceSetupPage(facade, files)),
        ("/setup/static/{name}", files),
        ("/setup/api/server", ServerResource(web)),
        ("/setup/api/log", LogResource(web.logs)),
        ("/setup/api/log.txt", LogText(web.logs)),
        ("/setup/api/safety", SafetyResource(web)),
        ("/setup/api/safety/discover", SafetyDiscoverResource(web)),
        ("/setup/api/safety/test", SafetyTestResource(web)),
        ("/setup/api/telescope/{number}/status", StatusResource(web)),
        ("/setup/api/telescope/{number}/settings", SettingsResource(web)),
        ("/setup/api/telescope/{number}/action/{name}", ActionResource(web)),
        ("/setup/api/telescope/{number}/trace", TraceResource(web)),
        ("/setup/api/objects", ObjectSearch(web)),
        ("/setup/api/telescope/{number}/object", ObjectDetails(web)),
        ("/setup/api/telescope/{number}/goto", GotoResource(web)),
        ("/setup/api/telescope/{number}/goto/verdict", GotoVerdict(web)),
        ("/setup/api/telescope/{number}/sync", SyncResource(web)),
        ("/setup/api/telescope/{number}/sky", SkyResource(web)),
        ("/setup/api/telescope/{number}/pointing-model", PointingModelResource(web)),
        ("/setup/api/telescope/{number}/satellites", SatellitesResource(web)),
        ("/setup/api/telescope/{number}/satellites/follow", FollowResource(web)),
        ("/setup/api/telescope/{number}/trace.txt", TraceText(web)),
        ("/setup/api/telescope/{number}/survey", SurveyResource(web)),
        ("/setup/api/telescope/{number}/survey.txt", SurveyText(web)),
        *guide_routes(),
    ]


__all__ = ["CSRF_HEADER", "LogBuffer", "StaticFiles", "check_same_origin", "log_buffer", "setup_routes", "static_dir"]
