"""Disturbances: what pushes the vehicle besides its rotors.

- ``base``: the ``Disturbance`` interface (a template: subclass it to add a model) and ``Sum``.
- ``forces``: time-profile models for the external force d_x (world frame) and torque d_Ω
  (body frame): ``Constant``, ``Window`` (step on/off), ``AtanRamp`` (the paper's
  Scenario I), ``Sinusoid``, ``Impulse``. Compose them with ``+``; ``model.during(a, b)``
  switches one on for ``a <= t < b``.
- ``ground_effect``: the in-ground-effect thrust multiplier (the paper's law and
  Cheeseman–Bennett's).
"""

from quad_dob_env.disturbances.base import Disturbance, Sum
from quad_dob_env.disturbances.forces import AtanRamp, Constant, Impulse, Sinusoid, Window
from quad_dob_env.disturbances.ground_effect import GROUND_EFFECT_MODELS, GroundEffect

__all__ = [
    "GROUND_EFFECT_MODELS",
    "AtanRamp",
    "Constant",
    "Disturbance",
    "GroundEffect",
    "Impulse",
    "Sinusoid",
    "Sum",
    "Window",
]
