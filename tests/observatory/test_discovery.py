"""Finding the SafetyMonitor and the roof by Alpaca discovery (the page's *Find devices*), on a private LAN.

Broadcasts only inside network namespaces (tests/netns.py): host A runs the server's finder; host B is an
observatory computer running alpaca-simulators (PyPI: a SafetyMonitor and a Dome) with an Alpaca
discovery responder beside it (alpaca-simulators has none of its own, and no management API, so its devices
are found by number); host C runs a real alpaca-zwo server (discovery and the management API: a Telescope,
listed as another device). The found URLs are then read from A, as the interlock will read them.
"""

from __future__ import annotations

import json
from pathlib import Path

from tests.netns import NetnsLan, lan_fixture

lan3 = lan_fixture(3)

OBSERVATORY = r"""
import subprocess, sys
from alpaca_zwo.alpaca.discovery import DiscoveryResponder
config = sys.argv[1]
code = "from alpaca_simulators.run_simulator import main; main()"
sim = subprocess.Popen([sys.executable, "-c", code, "--host", "0.0.0.0", "--port", "11111", "--config", config],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
for line in sim.stdout:
    if "Uvicorn running" in line:
        break
responder = DiscoveryResponder(11111, 32227)
responder.start()
print("READY", flush=True)
sys.stdin.readline()
responder.stop()
sim.terminate()
sim.wait()
"""

TELESCOPE = r"""
import sys
from alpaca_zwo.config.settings import ServerSettings, Settings, assign_unique_ids
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.server import AlpacaZwoServer
store = SettingsStore(assign_unique_ids(Settings(server=ServerSettings(host="0.0.0.0", port=11111,
                                                                       discovery_port=32227))))
server = AlpacaZwoServer(store)
server.start()
print("READY", flush=True)
sys.stdin.readline()
server.stop()
"""

FIND = r"""
import dataclasses, json, sys
from alpaca_zwo.alpaca.finder import find_devices
from alpaca_zwo.alpaca.remote import RemoteDevice
servers = find_devices(sys.argv[1])
found = [dataclasses.asdict(s) for s in servers]
reads = {d.url: RemoteDevice(d.url, client_id=9, timeout=5).get("issafe" if d.type == "SafetyMonitor"
                                                                 else "shutterstatus")
         for s in servers for d in s.devices}
print(json.dumps({"servers": found, "reads": reads}))
"""


def test_find_devices_by_broadcast_and_by_host(lan3: NetnsLan, tmp_path: Path) -> None:
    a, b, c = lan3.hosts
    observatory = b.spawn_python(OBSERVATORY, str(tmp_path / "simulators.yaml"))
    observatory.expect("READY", timeout=30)
    telescope = c.spawn_python(TELESCOPE)
    telescope.expect("READY", timeout=30)
    try:
        found = json.loads(a.python(FIND, "", timeout=60).strip().splitlines()[-1])
        servers = {s["address"]: s for s in found["servers"]}
        assert set(servers) == {f"{b.ipv4}:11111", f"{c.ipv4}:11111"}, servers
        sims = servers[f"{b.ipv4}:11111"]
        assert [(d["type"], d["number"]) for d in sims["devices"]] == [("SafetyMonitor", 0), ("Dome", 0)], sims
        monitor, roof = (d["url"] for d in sims["devices"])
        assert monitor == f"http://{b.ipv4}:11111/api/v1/safetymonitor/0"
        assert roof == f"http://{b.ipv4}:11111/api/v1/dome/0"
        assert found["reads"] == {monitor: True, roof: 1}  # safe; the simulator's shutter starts closed
        zwo = servers[f"{c.ipv4}:11111"]
        assert zwo["devices"] == [] and zwo["other_devices"] == 1 and zwo["name"] == "alpaca-zwo", zwo
        # Directed at one host (a monitor on another subnet): only that one answers.
        only = json.loads(a.python(FIND, b.ipv4, timeout=60).strip().splitlines()[-1])
        assert [s["address"] for s in only["servers"]] == [f"{b.ipv4}:11111"]
    finally:
        observatory.send("stop")
        telescope.send("stop")
        observatory.stop()
        telescope.stop()
