"""The pointing model on the page: ``GET/POST /setup/api/telescope/{number}/pointing-model``.

GET reads the model (points with their residuals and where they were taken on the sky, terms ± σ,
RMS, the switch, the last refusal); POST ``{"clear": true}`` and/or ``{"enabled": bool}`` changes it,
as the zwo:PointingModel Action does (docs/pointing-model.md). Readable whether or not a client is
connected: the model is kept beside the settings.
"""

from __future__ import annotations

import falcon

from .context import Resource
from .http import ApiError, api_errors, check_same_origin, flag, only_keys, send


class PointingModelResource(Resource):
    """The model of telescope ``number``: read it, clear it, switch it."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            send(resp, self.web.device(number).pointing_model())

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        check_same_origin(req)
        with api_errors(resp):
            body = self.body(req)
            only_keys(body, {"clear", "enabled"}, "key(s)")
            clear = flag(body, "clear") if "clear" in body else False
            if "clear" in body and not clear:
                raise ApiError(400, "clear must be true (it forgets every point)")
            enabled = flag(body, "enabled") if "enabled" in body else None
            send(resp, self.web.device(number).change_pointing_model(clear, enabled))
