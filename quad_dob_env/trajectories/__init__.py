"""Reference trajectories with analytic derivatives up to snap, and the heading b1d.

- ``base``: ``Reference`` (the batched values a controller needs) and the ``Trajectory``
  template: implement ``position_derivatives`` and ``yaw_derivatives`` to add one.
- ``library``: ``PaperHelix`` (the paper's reference), ``Hover``, ``Circle``,
  ``Lemniscate``, ``TakeoffHoverLanding`` (C³ vertical profile), ``WaypointHops``
  (rest-to-rest C³ hops through 3-D waypoints), ``RampedStart`` (any of them on a clock
  that starts from rest).
- ``polynomial``: ``PiecewisePolynomial``, the Crazyflie firmware's piecewise polynomial
  references with its time scale (Crazyswarm2's trajectory files).
- ``family``: ``TrajectoryFamily`` (members, one per vehicle, drawn at each reset) and
  ``random_references`` (a seeded pool of smooth random references, by kind).

May import ``validation`` and numpy; nothing of the vehicle or the envs.
"""

from quad_dob_env.trajectories.base import REFERENCE_FIELDS, Reference, Trajectory
from quad_dob_env.trajectories.family import REFERENCE_KINDS, TrajectoryFamily, random_references
from quad_dob_env.trajectories.library import (
    Circle,
    Harmonic,
    Hover,
    Lemniscate,
    PaperHelix,
    RampedStart,
    TakeoffHoverLanding,
    WaypointHops,
)
from quad_dob_env.trajectories.polynomial import PiecewisePolynomial

__all__ = [
    "REFERENCE_FIELDS",
    "REFERENCE_KINDS",
    "Circle",
    "Harmonic",
    "Hover",
    "Lemniscate",
    "PaperHelix",
    "PiecewisePolynomial",
    "RampedStart",
    "Reference",
    "TakeoffHoverLanding",
    "Trajectory",
    "TrajectoryFamily",
    "WaypointHops",
    "random_references",
]
