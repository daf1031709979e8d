"""The falcon application: Alpaca routing, transaction IDs, reply envelope and management API.

Every device member is served by one resource that dispatches through dictionaries built once
from the member table, because cheap property GETs dominate real traffic (N.I.N.A. and PHD2
poll several per second each) and their cost is mostly this layer's. Handlers see plain Python
values; AlpacaError becomes HTTP 200 + ErrorNumber in one error handler; any other exception is
a bug and becomes HTTP 500 without taking the server down.
"""

from __future__ import annotations

import base64
import binascii
import hmac
import logging
from collections.abc import Callable, Iterable, Sequence
from time import perf_counter
from typing import Any, NamedTuple

import falcon

from alpaca_zwo._exceptions import AlpacaError
from alpaca_zwo.alpaca.device import AlpacaDevice, handler_for, missing_handlers
from alpaca_zwo.alpaca.errors import (
    access_log,
    handle_bad_request,
    handle_http_error,
    handle_unexpected,
    log,
    unmatched,
)
from alpaca_zwo.alpaca.hosts import HostGuard
from alpaca_zwo.alpaca.management import ServerInfo, management_routes
from alpaca_zwo.alpaca.members import DEVICE_MEMBERS, Member, Param
from alpaca_zwo.alpaca.params import PARSERS, BadRequest, form_fields, missing, parse_id, query_fields
from alpaca_zwo.alpaca.render import RENDERERS, TransactionCounter, error_body, method_body, value_body
from alpaca_zwo.clients import ClientKey, ClientRegistry, current_client

DEVICE_TYPE = "telescope"
JSON = "application/json"
_DEBUG, _INFO = logging.DEBUG, logging.INFO


class _Endpoint(NamedTuple):
    """A member bound to one device, with everything the hot path needs precomputed."""

    member: Member
    call: Callable[..., Any]
    fields: tuple[tuple[str, Param, Callable[[str, str], object]], ...]  # (lookup key, param, parser)
    kwargs: tuple[str, ...]
    render: Callable[[object], object] | None
    has_value: bool


def _bind(device: AlpacaDevice, members: Iterable[Member], case_sensitive: bool) -> dict[str, _Endpoint]:
    """Each member's handler looked up once (the owner's, or the constant's), so a request makes no lookups."""
    table = {}
    for m in members:
        call = handler_for(device, m)
        if call is None:  # create_app checked every handler first
            raise TypeError(f"{type(device).__name__} lacks {m.answered_by}")
        fields = tuple((p.name if case_sensitive else p.name.lower(), p, PARSERS[p.type]) for p in m.params)
        table[m.path] = _Endpoint(m, call, fields, tuple(p.kwarg for p in m.params),
                                  RENDERERS.get(m.returns) if m.returns else None, m.returns is not None)
    return table


class DeviceApi:
    """``/api/v1/{device_type}/{device_number}/{member}`` for every device and member."""

    def __init__(self, devices: Sequence[AlpacaDevice], registry: ClientRegistry,
                 counter: TransactionCounter, max_body_bytes: int) -> None:
        members = DEVICE_MEMBERS[DEVICE_TYPE]
        # {device_type: {device_number text: (GET endpoints, PUT endpoints)}}
        self._routes: dict[str, dict[str, tuple[dict[str, _Endpoint], dict[str, _Endpoint]]]] = {
            DEVICE_TYPE: {
                str(number): (_bind(device, (m for m in members if m.verb == "GET"), False),
                              _bind(device, (m for m in members if m.verb == "PUT"), True))
                for number, device in enumerate(devices)
            }
        }
        self._registry = registry
        self._counter = counter
        self._max_body = max_body_bytes
        self._keys: dict[str, dict[int, ClientKey]] = {}

    # --- responders -----------------------------------------------------------------------------
    def on_get(self, req: falcon.Request, resp: falcon.Response, device_type: str, device_number: str,
               member: str) -> None:
        started = perf_counter()
        endpoint = self._endpoint(device_type, device_number, member, 0)
        fields = query_fields(req.query_string)
        self._serve(req, resp, endpoint, fields, fields.get("clientid"), fields.get("clienttransactionid"),
                    started)

    def on_put(self, req: falcon.Request, resp: falcon.Response, device_type: str, device_number: str,
               member: str) -> None:
        started = perf_counter()
        endpoint = self._endpoint(device_type, device_number, member, 1)
        fields = form_fields(self._read_body(req))
        # Form names are case-sensitive: a miscased ClientTransactionID is simply absent (echo 0).
        self._serve(req, resp, endpoint, fields, fields.get("ClientID"), fields.get("ClientTransactionID"),
                    started)

    # --- the hot path -----------------------------------------------------------------------------
    def _serve(self, req: falcon.Request, resp: falcon.Response, endpoint: _Endpoint, fields: dict[str, str],
               raw_client_id: str | None, raw_ctid: str | None, started: float) -> None:
        client_id = parse_id("ClientID", raw_client_id)
        ctid = parse_id("ClientTransactionID", raw_ctid)
        args = []
        for key, param, parse in endpoint.fields:
            text = fields.get(key)
            if text is None:
                text = param.default
                if text is None:
                    raise missing(param, fields, case_sensitive=endpoint.member.verb == "PUT")
            args.append(parse(param.name, text))

        client = self._client_key(req.remote_addr, client_id)
        self._registry.touch(client, req.user_agent or "")
        # What the AlpacaError handler needs to shape its reply (a plain tuple: this is per request).
        req.context.alpaca = (endpoint, ctid, client, started, args)
        token = current_client.set(client)
        try:
            if not args:
                result = endpoint.call()
            elif endpoint.member.setter:
                result = endpoint.call(args[0])
            else:
                result = endpoint.call(**dict(zip(endpoint.kwargs, args, strict=True)))
        finally:
            current_client.reset(token)

        stid = self._counter.next()
        if endpoint.has_value:
            if endpoint.render is not None:
                result = endpoint.render(result)
            resp.data = value_body(result, ctid, stid)
        else:
            resp.data = method_body(ctid, stid)
        resp.content_type = JSON
        if endpoint.member.verb == "PUT" and log.isEnabledFor(_INFO):
            log.info("%s(%s) by %s: ok", endpoint.member.name, _describe(endpoint, args), client)
        if access_log.isEnabledFor(_DEBUG):
            access_log.debug("%s %s client=%s ctid=%d stid=%d -> 200 (%.2f ms)", req.method, req.path,
                             client, ctid, stid, (perf_counter() - started) * 1000)

    def handle_alpaca_error(self, req: falcon.Request, resp: falcon.Response, ex: AlpacaError,
                            params: Any) -> None:
        """The one place an ASCOM failure becomes HTTP 200 + ErrorNumber/ErrorMessage."""
        call: tuple[_Endpoint, int, ClientKey, float, list[object]] | None = getattr(req.context, "alpaca", None)
        number = ex.number or 0x500  # 0 would read as success to every client
        message = ex.message or type(ex).__name__
        stid = self._counter.next()
        resp.status = 200
        resp.content_type = JSON
        if call is None:  # raised outside a device call (e.g. by an extra route)
            resp.data = error_body(None, 0, stid, number, message)
            return
        endpoint, ctid, client, started, args = call
        resp.data = error_body(endpoint.member.error_value, ctid, stid, number, message)
        if endpoint.member.verb == "PUT" and log.isEnabledFor(_INFO):
            log.info("%s(%s) by %s: error 0x%X %s", endpoint.member.name, _describe(endpoint, args), client,
                     number, message)
        if access_log.isEnabledFor(_DEBUG):
            access_log.debug("%s %s client=%s ctid=%d stid=%d -> 200 error 0x%X (%.2f ms)", req.method,
                             req.path, client, ctid, stid, number, (perf_counter() - started) * 1000)

    # --- helpers ----------------------------------------------------------------------------------
    def _endpoint(self, device_type: str, device_number: str, member: str, verb: int) -> _Endpoint:
        numbers = self._routes.get(device_type)
        if numbers is None:
            raise BadRequest(f"Unsupported device type {device_type!r}: this server has {DEVICE_TYPE}")
        tables = numbers.get(device_number)
        if tables is None:
            raise BadRequest(f"No {device_type} with device number {device_number!r}: "
                             f"this server has {', '.join(numbers) or 'none'}")
        endpoint = tables[verb].get(member)
        if endpoint is None:
            if member in tables[1 - verb]:
                allowed = "PUT" if verb == 0 else "GET"
                raise falcon.HTTPMethodNotAllowed([allowed], description=f"{member} accepts only {allowed}")
            raise BadRequest(f"Unknown {device_type} member {member!r} (member names are lower case)")
        return endpoint

    def _read_body(self, req: falcon.Request) -> bytes:
        length = req.content_length
        if not length:
            return b""
        if length > self._max_body:
            # Refuse before reading: nothing beyond the limit is ever pulled into memory.
            raise falcon.HTTPContentTooLarge(
                description=f"Request body of {length} bytes exceeds the {self._max_body} byte limit")
        return req.stream.read(length)

    def _client_key(self, address: str, client_id: int) -> ClientKey:
        # Reuse ClientKey objects: the same few clients make nearly every request.
        by_id = self._keys.get(address)
        if by_id is None:
            if len(self._keys) >= 1024:
                self._keys.clear()
            by_id = self._keys[address] = {}
        key = by_id.get(client_id)
        if key is None:
            if len(by_id) >= 1024:
                by_id.clear()
            key = by_id[client_id] = ClientKey(address, client_id)
        return key


def _describe(endpoint: _Endpoint, args: list[object]) -> str:
    return ", ".join(f"{p.name}={a!r}" for (_, p, _), a in zip(endpoint.fields, args, strict=True))


class BasicAuth:
    """Optional HTTP basic authentication on every route (Alpaca permits it; ConformU can send it)."""

    def __init__(self, username: str, password: str) -> None:
        self._username = username.encode()
        self._password = password.encode()

    def process_request(self, req: falcon.Request, resp: falcon.Response) -> None:
        header = req.get_header("Authorization") or ""
        scheme, _, encoded = header.partition(" ")
        if scheme.lower() == "basic":
            try:
                username, sep, password = base64.b64decode(encoded.strip(), validate=True).partition(b":")
            except (binascii.Error, ValueError):
                sep = b""
            if sep:
                # Compare both parts, always: no early exit that would time which one was wrong.
                good_user = hmac.compare_digest(username, self._username)
                good_password = hmac.compare_digest(password, self._password)
                if good_user and good_password:
                    return
        raise falcon.HTTPUnauthorized(description="Authentication required",
                                      challenges=['Basic realm="alpaca-zwo", charset="UTF-8"'])


class HostCheck:
    """Refuse (403, one line saying what to do) a request that names a host this server is not.

    The guard against DNS rebinding (see :mod:`alpaca_zwo.alpaca.hosts`). Every request is judged
    (Alpaca GETs too: they read the site's coordinates as the setup page does) except GET/HEAD of
    the open paths: the page and its files, which hold nothing private, so a person who opened the
    page by an unknown name sees the refusal of its first API call, saying what to do. It runs
    before basic auth, so a rebinding page never makes the browser ask for the password.
    """

    def __init__(self, guard: HostGuard, open_paths: Iterable[str] = ()) -> None:
        self._guard = guard
        self._exact = frozenset(p for p in open_paths if not p.endswith("/"))
        self._prefixes = tuple(p for p in open_paths if p.endswith("/"))
        self._reported: set[str] = set()

    def process_request(self, req: falcon.Request, resp: falcon.Response) -> None:
        if req.method in _READS and (req.path in self._exact or req.path.startswith(self._prefixes)):
            return
        env = req.env  # the WSGI names directly: cheaper than get_header on every Alpaca GET
        reason = self._guard.refusal(env.get("HTTP_HOST"), env.get("HTTP_ORIGIN"))
        if reason is not None:
            if reason not in self._reported:  # once per refusal: a looping page must not flood the log
                if len(self._reported) >= 64:
                    self._reported.clear()
                self._reported.add(reason)
                log.warning("%s %s from %s: %s", req.method, req.path, req.remote_addr, reason)
            raise falcon.HTTPForbidden(description=reason)


_READS = frozenset({"GET", "HEAD"})


def _open_paths(routes: Iterable[tuple[str, object]]) -> list[str]:
    """The paths of routes whose resource says ``any_host = True``: a template's fixed part, up to its
    first field (``/setup/static/{name}`` -> ``/setup/static/``)."""
    return [template.partition("{")[0] for template, resource in routes if getattr(resource, "any_host", False)]


def create_app(devices: Sequence[AlpacaDevice], registry: ClientRegistry, info: ServerInfo, *,
               max_body_bytes: int = 65536, basic_auth: tuple[str, str] | None = None,
               extra_routes: Iterable[tuple[str, object]] = (),
               host_guard: HostGuard | None = None) -> falcon.App[falcon.Request, falcon.Response]:
    """Build the WSGI app serving ``devices`` as telescope 0, 1, ... plus the management API.

    ``extra_routes`` are ``(uri_template, resource)`` pairs mounted as-is (e.g. the /setup pages);
    they share basic auth, the host check and the plain-text error replies. ``host_guard`` None
    serves any Host (tests of other layers); the server always passes one.
    """
    members = DEVICE_MEMBERS[DEVICE_TYPE]
    for number, device in enumerate(devices):
        lacking = missing_handlers(device, members)
        if lacking:
            raise TypeError(f"device {number} ({type(device).__name__}) lacks {', '.join(lacking)}")

    counter = TransactionCounter()
    extra_routes = list(extra_routes)
    middleware: list[HostCheck | BasicAuth] = [HostCheck(host_guard, _open_paths(extra_routes))] if host_guard else []
    if basic_auth:
        middleware.append(BasicAuth(*basic_auth))
    app = falcon.App(middleware=middleware)
    api = DeviceApi(devices, registry, counter, max_body_bytes)
    app.add_route("/api/v1/{device_type}/{device_number}/{member}", api)
    for path, resource in management_routes(devices, DEVICE_TYPE, info, registry, counter):
        app.add_route(path, resource)
    for path, resource in extra_routes:
        app.add_route(path, resource)
    app.add_sink(unmatched, "/")

    # Falcon picks the most specific handler by the exception's MRO.
    app.add_error_handler(Exception, handle_unexpected)
    app.add_error_handler(falcon.HTTPError, handle_http_error)
    app.add_error_handler(BadRequest, handle_bad_request)
    app.add_error_handler(AlpacaError, api.handle_alpaca_error)
    return app
