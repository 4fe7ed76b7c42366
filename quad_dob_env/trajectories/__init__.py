"""Reference trajectories with analytic derivatives up to snap, and the heading b1d.

- ``base``: ``Reference`` (the batched values a controller needs) and the ``Trajectory``
  template: implement ``position_derivatives`` and ``yaw_derivatives`` to add one.
- ``library``: ``PaperHelix`` (the paper's reference), ``Hover``, ``Circle``,
  ``Lemniscate``, ``TakeoffHoverLanding`` (C³ vertical profile).

May import ``validation`` and numpy; nothing of the vehicle or the envs.
"""

from quad_dob_env.trajectories.base import Reference, Trajectory
from quad_dob_env.trajectories.library import (
    Circle,
    Harmonic,
    Hover,
    Lemniscate,
    PaperHelix,
    TakeoffHoverLanding,
)

__all__ = [
    "Circle",
    "Harmonic",
    "Hover",
    "Lemniscate",
    "PaperHelix",
    "Reference",
    "TakeoffHoverLanding",
    "Trajectory",
]
