"""Bridges: other programs' protocols served on top of the same Telescope as Alpaca.

Each bridge drives the mount only through the Telescope's public methods, so the limits,
parking rules, aborts and client reference counting that apply to Alpaca apply to it too.
Owns Stellarium's telescope server (``stellarium``) and the shared ZWO-protocol port (``zwo_port``:
the sockets; ``zwo_replies``: the command table; ``zwo_session``: one connection's state;
``zwo_clock_site``: the clock and site commands), their door (``admission``: the networks a
bridge accepts, the ZWO port's first-bytes rule, the once-a-minute refusal log), and the one client
among them, ``gpsd``: the site read from a GPS receiver through gpsd.

May import ``telescope``, ``mount`` (types), ``config``, ``zwo``, ``clients`` and ``sky``.
"""
