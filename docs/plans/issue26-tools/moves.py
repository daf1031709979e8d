# ruff: noqa  (a one-off tool of the issue-26 plan, deleted once the restructuring is done)
"""Issue 26 step 1: the old module path -> new module path map, used by git mv and the import rewrite."""
MOVES = {
    # zwo/: the mount's language and line
    "alpaca_zwo.protocol": "alpaca_zwo.zwo.protocol",
    "alpaca_zwo.wire_values": "alpaca_zwo.zwo.wire_values",
    "alpaca_zwo.request_framer": "alpaca_zwo.zwo.request_framer",
    "alpaca_zwo.link": "alpaca_zwo.zwo.link",
    "alpaca_zwo.firmware": "alpaca_zwo.zwo.firmware",
    "alpaca_zwo.devices": "alpaca_zwo.zwo.devices",
    # mount/: typed operations, state snapshot, estimator, settings cache
    "alpaca_zwo.mount": "alpaca_zwo.mount.operations",
    "alpaca_zwo.mount_state": "alpaca_zwo.mount.state",
    "alpaca_zwo.estimator": "alpaca_zwo.mount.estimator",
    "alpaca_zwo.settings_cache": "alpaca_zwo.mount.settings_cache",
    # telescope/: ASCOM semantics, connection, capabilities, Actions
    "alpaca_zwo.telescope": "alpaca_zwo.telescope.device",
    "alpaca_zwo.telescope_connection": "alpaca_zwo.telescope.connection",
    "alpaca_zwo.telescope_caps": "alpaca_zwo.telescope.capabilities",
    "alpaca_zwo.actions": "alpaca_zwo.telescope.actions",
    # config/: settings, the file, the live store
    "alpaca_zwo.config": "alpaca_zwo.config.settings",
    "alpaca_zwo.config_file": "alpaca_zwo.config.file",
    "alpaca_zwo.store": "alpaca_zwo.config.store",
    # alpaca/: how clients reach the server (listener check, LAN addresses) beside HTTP/discovery/mDNS
    "alpaca_zwo.listen_check": "alpaca_zwo.alpaca.listen_check",
    "alpaca_zwo.local_addresses": "alpaca_zwo.alpaca.local_addresses",
}
