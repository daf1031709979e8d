"""ASCOM ITelescopeV4 semantics for one mount.

Owns ``device.Telescope`` (the member surface: validation, targets, slews, syncs, park), its parts
``connection.Connection`` (clients, opening and lingering the link, the mount settings a connect
pushes) and ``capabilities.Capabilities`` (Can* flags, axis/guide/offset rates, site), the pure
target checks (``pointing``), and the ``zwo:*`` Actions (``actions``).

May import ``motion``, ``mount``, ``config``, ``zwo``, ``clients`` and ``sky``; never ``alpaca``,
``web`` or the bridges (they call it).
"""
