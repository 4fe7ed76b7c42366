"""Geometric tracking control on SE(3) (Lee, Leok, McClamroch, CDC 2010), z up, with an
optional nonlinear disturbance observer.

``F = -kx ex - kv ev + m g e3 + m ẍd - d̂x``, ``f = F · R e3``, ``Rd`` from ``F`` and ``b1d``,
``M = -kR eR - kΩ eΩ + Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) - d̂Ω``.

Ωd and Ω̇d come from differentiating Rd analytically: F's first two derivatives use the
trajectory's jerk and snap and the model's prediction of the vehicle's acceleration and
jerk, ``v̇ = -g e3 + (f R e3 + d̂x)/m`` (the estimate d̂x is held constant in them).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from baselines.attitude import attitude_errors, body_z_rate, desired_attitude
from baselines.base import E3, Controller
from baselines.observer import NonlinearDisturbanceObserver
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.so3 import cross, hat
from quad_dob_env.trajectories import Reference
from quad_dob_env.validation import as_finite

# The paper's (and Lee 2010's) gains; kx and kv scale with the vehicle's mass.
PAPER_GAINS = {"kx_per_mass": 16.0, "kv_per_mass": 5.6, "kR": 8.81, "kOmega": 2.54}


def _dot(a: NDArray, b: NDArray) -> NDArray:
    return np.einsum("ni,ni->n", a, b)


class GeometricController(Controller):
    """Lee 2010 geometric tracking controller; with ``observer`` it is geometric + NDOB.

    Gains: ``kx = kx_per_mass m``, ``kv = kv_per_mass m`` (paper: 16 m, 5.6 m), ``kR``,
    ``kOmega`` (paper: 8.81, 2.54); each may be a scalar or a per-axis 3-vector.
    """

    name = "geometric"

    def __init__(self, kx_per_mass: ArrayLike = 16.0, kv_per_mass: ArrayLike = 5.6,
                 kR: ArrayLike = 8.81, kOmega: ArrayLike = 2.54,
                 observer: NonlinearDisturbanceObserver | None = None) -> None:
        super().__init__()
        self.gains = {}
        for key, value in (("kx_per_mass", kx_per_mass), ("kv_per_mass", kv_per_mass),
                           ("kR", kR), ("kOmega", kOmega)):
            gain = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
            for component in gain:
                as_finite(component, f"GeometricController.{key}", 0.0, strictly=True)
            self.gains[key] = gain
        self.observer = observer
        if observer is not None:
            self.name = "geometric-ndob"

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None) -> None:
        super().reset(num_vehicles, vehicle, dt, indices)
        if self.observer is not None:
            self.observer.reset(num_vehicles, vehicle, dt, indices)

    def compute(self, time: NDArray, state: VehicleState,
                reference: Reference) -> tuple[NDArray, NDArray]:
        vehicle = self.vehicle
        m, g, J = vehicle.mass, vehicle.gravity, vehicle.inertia_matrix
        kx, kv = self.gains["kx_per_mass"] * m, self.gains["kv_per_mass"] * m
        if self.observer is not None:
            force_estimate, torque_estimate = self.observer.estimate(state)
        else:
            force_estimate = torque_estimate = np.zeros_like(state.position)
        R, w = state.rotation, state.angular_velocity
        position_error = state.position - reference.position
        velocity_error = state.velocity - reference.velocity
        force = (-kx * position_error - kv * velocity_error + m * g * E3
                 + m * reference.acceleration - force_estimate)
        body_z = R[:, :, 2]
        thrust = _dot(force, body_z)
        body_z_dot = body_z_rate(R, w)
        # model-predicted acceleration and jerk errors: v̇ = -g e3 + (f R e3 + d̂x) / m
        acceleration_error = (-g * E3 + (thrust[:, None] * body_z + force_estimate) / m
                              - reference.acceleration)
        force_dot = -kx * velocity_error - kv * acceleration_error + m * reference.jerk
        thrust_dot = _dot(force_dot, body_z) + _dot(force, body_z_dot)
        jerk_error = ((thrust_dot[:, None] * body_z + thrust[:, None] * body_z_dot) / m
                      - reference.jerk)
        force_ddot = -kx * acceleration_error - kv * jerk_error + m * reference.snap
        desired = desired_attitude(force, force_dot, force_ddot, reference.heading,
                                   reference.heading_rate, reference.heading_acceleration)
        attitude_error, rate_error, r_t_rd = attitude_errors(R, w, desired)
        desired_rate_body = np.einsum("nij,nj->ni", r_t_rd, desired.angular_velocity)
        desired_acceleration_body = np.einsum("nij,nj->ni", r_t_rd,
                                              desired.angular_acceleration)
        # M = -kR eR - kΩ eΩ + Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) - d̂Ω
        moment = (-self.gains["kR"] * attitude_error - self.gains["kOmega"] * rate_error
                  + cross(w, w @ J.T)
                  - (np.einsum("nij,nj->ni", hat(w), desired_rate_body)
                     - desired_acceleration_body) @ J.T
                  - torque_estimate)
        self.diagnostics = {
            "desired_rotation": desired.rotation,
            "desired_angular_velocity": desired.angular_velocity,
            "desired_force": force,
            "attitude_error": attitude_error,
            "rate_error": rate_error,
            "force_estimate": force_estimate,
            "torque_estimate": torque_estimate,
        }
        return thrust, moment

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        if self.observer is not None:
            self.observer.update(state, thrust, moment)

    def describe(self) -> dict[str, Any]:
        info: dict[str, Any] = {"name": self.name,
                                **{k: v.tolist() for k, v in self.gains.items()}}
        if self.observer is not None:
            info["Ks"] = self.observer.translational_gain
            info["Km"] = self.observer.rotational_gain.tolist()
        return info
