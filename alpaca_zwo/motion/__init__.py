"""Motion: the one owner of every motion of a mount (see ``supervisor.py`` for the lock rules)."""

from .kinds import MAX_MOTION_S, Motion, MotionKind, Phase
from .supervisor import MotionSupervisor

__all__ = ["MAX_MOTION_S", "Motion", "MotionKind", "MotionSupervisor", "Phase"]
