"""One mount as typed operations.

Owns ``operations.Mount`` (the commands, and the one poller that keeps the ``state.MountState``
snapshot fresh), the position estimator and the sync remainder (``estimator``), and the
mount-stored settings as last read (``settings_cache``), and the time reference: ``timekeeping``
(whose clock is right, the host's, the mount's or a client's, and when the mount's clock is set) on
``host_clock`` (whether the operating system's clock is synchronised). Owns the two frames: the mount's (what the
wire says) and the client's (the mount's plus the pointing model's correction, ``pointing_frame`` on
``pointing_model``'s least-squares TPoint fit of the syncs, plus the last sync's remainder).

May import ``zwo`` and ``sky``; never motion, the telescope or the configuration.
"""
