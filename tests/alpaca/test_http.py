"""HttpServer lifecycle: binding, serving in the background, and stopping cleanly."""

from __future__ import annotations

import os
import socket
import threading
import time

import falcon
import pytest
import requests

from alpaca_zwo.alpaca import HttpServer


class _Slow:
    def __init__(self) -> None:
        self.entered = threading.Event()

    def on_get(self, req: falcon.Request, resp: falcon.Response) -> None:
        self.entered.set()
        time.sleep(0.3)
        resp.text = "slow done"


def _app(resource: object | None = None) -> falcon.App:
    app = falcon.App()
    if resource is not None:
        app.add_route("/slow", resource)
    return app


def _threads() -> set[str]:
    return {t.name for t in threading.enumerate()}


def test_port_zero_binds_a_free_port_before_start() -> None:
    server = HttpServer(_app(), "127.0.0.1", 0)
    try:
        assert server.port > 0
        with socket.create_connection(("127.0.0.1", server.port), timeout=2):
            pass  # already listening (backlog) before start()
    finally:
        server.close()


def test_serves_with_ident_and_stops() -> None:
    before = _threads()
    server = HttpServer(_app(_Slow()), "127.0.0.1", 0, threads=2)
    server.start()
    port = server.port
    r = requests.get(f"http://127.0.0.1:{port}/slow", timeout=5)
    assert r.text == "slow done" and r.headers["Server"] == "alpaca-zwo"
    started = time.monotonic()
    server.close()
    assert time.monotonic() - started < 3
    with pytest.raises(requests.ConnectionError):
        requests.get(f"http://127.0.0.1:{port}/slow", timeout=2)
    time.sleep(0.05)
    assert _threads() <= before | {threading.current_thread().name}


def test_close_with_open_keepalive_connections_and_in_flight_request() -> None:
    slow = _Slow()
    server = HttpServer(_app(slow), "127.0.0.1", 0)
    server.start()
    idle = requests.Session()
    idle.get(f"http://127.0.0.1:{server.port}/slow", timeout=5)  # leaves a keep-alive connection open
    result: list[object] = []

    def fetch() -> None:
        try:
            result.append(requests.get(f"http://127.0.0.1:{server.port}/slow", timeout=5).status_code)
        except requests.RequestException as exc:
            result.append(exc)

    slow.entered.clear()
    worker = threading.Thread(target=fetch)
    worker.start()
    assert slow.entered.wait(2)
    started = time.monotonic()
    server.close()
    assert time.monotonic() - started < 3
    worker.join(5)
    assert result  # the in-flight client got an answer or a clean connection error, not a hang
    idle.close()


def test_close_is_idempotent_and_works_unstarted() -> None:
    server = HttpServer(_app(), "127.0.0.1", 0)
    server.close()
    server.close()
    started = HttpServer(_app(), "127.0.0.1", 0)
    started.start()
    started.close()
    started.close()


def test_context_manager_and_double_start() -> None:
    with HttpServer(_app(_Slow()), "127.0.0.1", 0) as server:
        assert requests.get(f"http://127.0.0.1:{server.port}/slow", timeout=5).status_code == 200
        with pytest.raises(RuntimeError):
            server.start()


def test_waitress_body_limit_option() -> None:
    with HttpServer(_app(_Slow()), "127.0.0.1", 0, max_request_body_size=10) as server:
        r = requests.put(f"http://127.0.0.1:{server.port}/slow", data="x" * 100, timeout=5)
        assert r.status_code == 413


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc")
def test_many_start_stop_cycles_leave_no_descriptors_behind() -> None:
    def open_fds() -> int:
        return len(os.listdir("/proc/self/fd"))

    baseline = open_fds()
    for _ in range(30):
        with HttpServer(_app(_Slow()), "127.0.0.1", 0, threads=2) as server, requests.Session() as session:
            session.get(f"http://127.0.0.1:{server.port}/nothing", timeout=5)
    assert open_fds() <= baseline + 2
