"""Motion: the one owner of every motion of a mount.

``supervisor.MotionSupervisor`` starts, watches, lands and stops every motion; it owns small parts,
each with its own state: ``guiding.Guiding`` (client pulses, alt-az timed moves), ``offsets.OffsetPayer``
(rate offsets, paid from the ledger in ``balance``), ``landing.Lander`` (landing exactly where asked),
``rest.RestDetector`` (rest from readings), ``limits.Limits`` (braking-aware limits), ``follow.Follower``
(a moving target followed with axis speeds: a satellite's pass) and ``kinds.Generation`` (the stop
generation every command's guard reads). ``flip.PierFlips`` runs GOTOs
that must land on a chosen pier side under a temporary meridian limit. ``interlock.Interlock`` is the
observatory's gate every start but a park asks (the safety monitor's verdict, written from above). Lock
rules: at the top of ``supervisor.py``.

May import mount, config, zwo, clients and sky.
"""

from .kinds import MAX_MOTION_S, Motion, MotionKind, Phase
from .supervisor import MotionSupervisor

__all__ = ["MAX_MOTION_S", "Motion", "MotionKind", "MotionSupervisor", "Phase"]
