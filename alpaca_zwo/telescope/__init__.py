"""ASCOM ITelescopeV4 semantics for one mount.

Owns ``device.Telescope`` (where the mount points and what it does: position, pier side, tracking,
slews, syncs, park, home, MoveAxis, pulses) and its parts, each answering its own Alpaca members as the
member table (``alpaca/members.py``) names them: ``connection.Connection`` (clients, opening and
lingering the link, the mount settings a connect pushes), ``capabilities.Capabilities`` (the Can*
flags that vary, the drive/offset/guide/axis rates, site), ``clock.SiteClock`` (UTCDate, sidereal
time), ``targets.Targets`` (targets, settle time) and ``raw_commands.RawCommands``; the pure target
checks (``pointing``), the ``zwo:*`` Actions (``actions``), and ``satellites.Satellites`` (kept TLE sets,
their passes: ``passes``, ``orbits``; the follow of one).

May import ``motion``, ``mount``, ``config``, ``zwo``, ``clients`` and ``sky``; never ``alpaca``,
``web`` or the bridges (they call it).
"""
