"""One mount as typed operations.

Owns ``operations.Mount`` (the commands, and the one poller that keeps the ``state.MountState``
snapshot fresh), the position estimator and the sync remainder (``estimator``), and the
mount-stored settings as last read (``settings_cache``). Owns the two frames: the mount's (what the
wire says) and the client's (the mount's plus the last sync's remainder).

May import ``zwo`` and ``sky``; never motion, the telescope or the configuration.
"""
