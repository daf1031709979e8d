"""The owner's survey on the page: run it on the connected mount, show the verdict, offer the report file.

``POST /setup/api/telescope/{number}/survey`` runs it (refused in words while the mount moves: the
facade says why) and answers the verdict; ``GET …/survey.txt`` downloads the last report, the same text
``alpaca-zwo --survey`` writes (docs/survey.md).
"""

from __future__ import annotations

import falcon

from ..facade import SurveyReport
from .context import Resource
from .http import ApiError, api_errors, check_same_origin, send, text_download


def _verdict(report: SurveyReport) -> dict[str, object]:
    return {
        "mount": report.identity(),
        "exchanges": len(report.exchanges),
        "stopped": report.stopped,
        "verdicts": [{"switch": v.switch, "state": v.state, "values": list(v.values), "line": v.line()}
                     for v in report.verdicts()],
    }


class SurveyResource(Resource):
    """``POST``: ask the mount the survey's read-only list now; the verdict, for the page to show."""

    def on_post(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        check_same_origin(req)
        with api_errors(resp):
            device = self.web.device(number)
            self.web.touch(req)
            send(resp, {"ok": True, **_verdict(device.survey())})


class SurveyText(Resource):
    """``GET``: the last survey's report file (404 with what to do when there is none yet)."""

    def on_get(self, req: falcon.Request, resp: falcon.Response, number: str) -> None:
        with api_errors(resp):
            report = self.web.device(number).last_survey
            if report is None:
                raise ApiError(404, "no survey yet: run one with the Survey button first")
            text_download(resp, report.text(), "alpaca-zwo-survey")
