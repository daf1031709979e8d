"""What every route of the page shares: the server's facade, the log buffer and the device lookup."""

from __future__ import annotations

import threading
from typing import Any

import falcon

from ..facade import ClientKey, DeviceFacade, ServerFacade
from .http import ApiError, page_client, read_json
from .logview import LogBuffer


class WebContext:
    """One per server, shared by its route resources."""

    def __init__(self, facade: ServerFacade, logs: LogBuffer) -> None:
        self.facade = facade
        self.logs = logs
        #: Serialises settings changes: validate, write the mount, write the file, as one step.
        self.settings_lock = threading.Lock()

    def device(self, number: str) -> DeviceFacade:
        """The telescope named by a URL segment; 404 for anything but ``0``..``N-1`` spelled plainly."""
        count = self.facade.device_count
        if number not in [str(i) for i in range(count)]:
            raise ApiError(404, f"no telescope {number!r} on this server (it has {count})")
        return self.facade.device(int(number))

    def touch(self, req: falcon.Request) -> ClientKey:
        """Record the page's activity: the MoveAxis watchdog stops a jog once the page goes quiet."""
        key = page_client(req)
        self.facade.touch_client(key, req.user_agent or "")
        return key


class Resource:
    """Base of the JSON API's route resources."""

    def __init__(self, web: WebContext) -> None:
        self.web = web

    def body(self, req: falcon.Request) -> dict[str, Any]:
        return read_json(req, self.web.facade.settings.server.max_body_bytes)
