"""Bridges: other programs' protocols served on top of the same Telescope as Alpaca.

Each bridge drives the mount only through the Telescope's public methods and parts, so the limits,
parking rules, aborts and client reference counting that apply to Alpaca apply to it too; what it
reads comes from those and from the published snapshot (``telescope.mount.state``), never from a
serial exchange of its own.
Owns Stellarium's telescope server (``stellarium``) and the shared ZWO-protocol port (``zwo_port``:
the sockets; ``zwo_backend``: the Telescope as the backend of ``zwo/dispatch.py``'s command table,
one per program with its own session), their door (``admission``: the networks a
bridge accepts, the ZWO port's first-bytes rule, the once-a-minute refusal log), and the one client
among them, ``gpsd``: the site read from a GPS receiver through gpsd.

May import ``telescope``, ``mount`` (types), ``config``, ``zwo``, ``clients`` and ``sky``.
"""
