"""The Alpaca Management API: how discovery clients learn what this server offers.

Clients reach these right after UDP discovery and before any device call, so they must answer
whatever state the devices are in; they read device names per request so a rename on the setup
page is visible at once.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import falcon

from alpaca_zwo.alpaca.device import AlpacaDevice
from alpaca_zwo.alpaca.params import parse_id, query_fields
from alpaca_zwo.alpaca.render import TransactionCounter, management_body
from alpaca_zwo.clients import ClientKey, ClientRegistry

#: Alpaca API versions served under /api/v{N}/.
API_VERSIONS = [1]


@dataclass(frozen=True)
class ServerInfo:
    """The /management/v1/description answer: the server as a whole, not one device."""

    server_name: str
    manufacturer: str
    manufacturer_version: str
    location: str = ""


class _ManagementResource:
    """One GET-only management endpoint; ``value`` builds its Value per request."""

    def __init__(self, value: Callable[[], object], registry: ClientRegistry,
                 counter: TransactionCounter) -> None:
        self._value = value
        self._registry = registry
        self._counter = counter

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        fields = query_fields(req.query_string)
        client_id = parse_id("ClientID", fields.get("clientid"))
        ctid = parse_id("ClientTransactionID", fields.get("clienttransactionid"))
        self._registry.touch(ClientKey(req.remote_addr, client_id), req.user_agent or "")
        value = self._value()
        resp.content_type = falcon.MEDIA_JSON
        resp.data = management_body(value, ctid, self._counter.next())


def management_routes(devices: Sequence[AlpacaDevice], device_type: str, info: ServerInfo,
                      registry: ClientRegistry, counter: TransactionCounter) -> list[tuple[str, object]]:
    """``(path, resource)`` pairs for the three management endpoints."""
    # The management API capitalises the type ("Telescope"); the device API path is lower case.
    type_name = device_type.capitalize()

    def description() -> dict[str, str]:
        return {"ServerName": info.server_name, "Manufacturer": info.manufacturer,
                "ManufacturerVersion": info.manufacturer_version, "Location": info.location}

    def configured_devices() -> list[dict[str, object]]:
        return [{"DeviceName": device.device_name, "DeviceType": type_name, "DeviceNumber": number,
                 "UniqueID": device.unique_id} for number, device in enumerate(devices)]

    def make(value: Callable[[], object]) -> _ManagementResource:
        return _ManagementResource(value, registry, counter)

    return [
        ("/management/apiversions", make(lambda: API_VERSIONS)),
        ("/management/v1/description", make(description)),
        ("/management/v1/configureddevices", make(configured_devices)),
    ]
