"""Batched rigid-body quadrotor dynamics.

- ``state``: ``VehicleState``, the batched (x, v, R, Ω).
- ``integrator``: the equations of motion (docs/design.md) and the CF4 Lie-group Runge–Kutta
  integrator, compiled per vehicle; the in-ground-effect thrust law it evaluates.
- ``actuation``: rotor allocation and saturation (``rotors``) or direct wrench limits
  (``wrench``), reporting what was actually applied.
- ``rotors``: the rotors' own physics, a switch each (Benchmark v2): motors on rotor speed,
  thrust uncertainty (per-episode k_F, battery sag), rotor drag and its moment, thrust with
  axial inflow.
- ``throttle``: Benchmark v3's throttle between autopilot and rotors: the thrust a throttle
  gives, what the autopilot believes of it, and the battery under both.

May import ``params``, ``so3``, ``validation`` and ``threads``; nothing above.
"""

from quad_dob_env.dynamics.actuation import (
    ACTUATION_CODES,
    Actuator,
    ActuatorArrays,
    AppliedCommand,
    actuate_vehicle,
    store_applied,
)
from quad_dob_env.dynamics.integrator import (
    NO_GROUND_EFFECT,
    BodyArrays,
    Forcing,
    RigidBody,
    ThrustLaw,
    actuator_wrench,
    advance_vehicle,
    all_finite,
    body_drag,
    lag_factor,
    load_vehicle,
    physics_arrays,
    sample,
    store_vehicle,
    thrust_multiplier,
    thrust_multiplier_scalar,
    vehicle_physics,
)
from quad_dob_env.dynamics.state import StateArrays, VehicleState

__all__ = [
    "ACTUATION_CODES",
    "NO_GROUND_EFFECT",
    "Actuator",
    "ActuatorArrays",
    "AppliedCommand",
    "BodyArrays",
    "Forcing",
    "RigidBody",
    "StateArrays",
    "ThrustLaw",
    "VehicleState",
    "actuate_vehicle",
    "actuator_wrench",
    "advance_vehicle",
    "all_finite",
    "body_drag",
    "lag_factor",
    "load_vehicle",
    "physics_arrays",
    "sample",
    "store_applied",
    "store_vehicle",
    "thrust_multiplier",
    "thrust_multiplier_scalar",
    "vehicle_physics",
]
