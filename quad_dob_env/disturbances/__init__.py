"""Disturbances: what pushes the vehicle besides its rotors.

- ``base``: the ``Disturbance`` interface (a template: subclass it to add a model), and
  the combinators every model has: ``Sum`` (``a + b``) and ``Window`` (``a.during(t0, t1)``).
- ``forces``: time-profile models for the external force d_x (world frame) and torque d_Ω
  (body frame): ``Constant``, ``AtanRamp`` (the paper's
  Scenario I), ``Sinusoid``, ``Impulse``. Compose them with ``+``; ``model.during(a, b)``
  switches one on for ``a <= t < b``.
- ``wind``: ``Gust`` (MIL-F-8785C 1-cosine) and ``Dryden`` turbulence; constant wind,
  steps and sinusoids are ``Constant(wind=...)``, ``.during`` and ``Sinusoid(wind=...)``.
- ``ground_effect``: the in-ground-effect thrust multiplier (the paper's law and
  Cheeseman–Bennett's).
- ``payload``: ``SuspendedPayload``, a point mass on a cable under the vehicle (Crazyswarm2's
  payload flights): a force that follows the vehicle's true state (``Disturbance.follow``).

Every model has three channels: force d_x (world, N), torque d_Ω (body, N m) and wind
velocity (world, m/s), which acts through the vehicle's drag.

May import ``params``, ``so3``, ``dynamics``, ``linalg``, ``rng``, ``validation`` and
``threads``; nothing above.
"""

from quad_dob_env.disturbances.base import Disturbance, Sum, Window, split_by_randomness
from quad_dob_env.disturbances.forces import AtanRamp, Constant, Impulse, Sinusoid
from quad_dob_env.disturbances.ground_effect import GROUND_EFFECT_MODELS, GroundEffect
from quad_dob_env.disturbances.payload import SuspendedPayload
from quad_dob_env.disturbances.wind import DRYDEN_INTENSITIES, Dryden, Gust

__all__ = [
    "DRYDEN_INTENSITIES",
    "GROUND_EFFECT_MODELS",
    "AtanRamp",
    "Constant",
    "Disturbance",
    "Dryden",
    "GroundEffect",
    "Gust",
    "Impulse",
    "Sinusoid",
    "Sum",
    "SuspendedPayload",
    "Window",
    "split_by_randomness",
]
