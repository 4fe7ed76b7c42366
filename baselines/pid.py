"""Cascaded PID: position PID -> desired thrust vector and attitude; attitude P -> rate
command; rate PID -> body moment. Integrators are clamped (anti-windup) and frozen while
the last command saturated the actuators.

Outer: ``a = ẍd - Kp ex - Kd ev - Ki ∫ex``, ``F = m (a + g e3)``, ``f = F · R e3``, Rd from
F and b1d. Middle: ``ω_cmd = RᵀRd Ωd_ff - K_att eR``. Inner: ``e_ω = Ω - ω_cmd``,
``M = Ω × JΩ + J (RᵀRd Ω̇d_ff - K_ω e_ω - K_ωi ∫e_ω - K_ωd ė_ω)``, ė_ω by backward difference.
Ωd_ff, Ω̇d_ff are the reference's flat feed-forward (``feedforward_attitude``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from baselines.attitude import track_thrust_vector
from baselines.base import E3, Controller, validated_gains
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.so3 import cross
from quad_dob_env.trajectories import Reference

PID_GAINS = {
    "position_kp": 16.0, "position_kd": 6.0, "position_ki": 6.0, "position_integral_limit": 0.3,
    "attitude_kp": 10.0, "rate_kp": 25.0, "rate_ki": 20.0, "rate_kd": 0.3,
    "rate_integral_limit": 0.2,
}


class CascadedPID(Controller):
    """Cascaded PID with the gains in ``PID_GAINS`` (1/s units, scaled by m and J)."""

    name = "pid"

    def __init__(self, **gains: float) -> None:
        super().__init__()
        self.gains = validated_gains("PID", PID_GAINS, gains, strictly_positive=False)

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None) -> None:
        super().reset(num_vehicles, vehicle, dt, indices)
        if indices is None:
            self.position_integral = np.zeros((num_vehicles, 3))
            self.rate_integral = np.zeros((num_vehicles, 3))
            self.previous_rate_error = np.zeros((num_vehicles, 3))
            self.saturated = np.zeros(num_vehicles, dtype=bool)
            self.fresh = np.ones(num_vehicles, dtype=bool)
        else:
            for array in (self.position_integral, self.rate_integral, self.previous_rate_error):
                array[indices] = 0.0
            self.saturated[indices] = False
            self.fresh[indices] = True

    def compute(self, time: NDArray, state: VehicleState,
                reference: Reference) -> tuple[NDArray, NDArray]:
        g, vehicle, dt = self.gains, self.vehicle, self.dt
        m, J = vehicle.mass, vehicle.inertia_matrix
        position_error = state.position - reference.position
        velocity_error = state.velocity - reference.velocity
        integrating = ~self.saturated[:, None]
        limit = g["position_integral_limit"]
        self.position_integral = np.clip(
            self.position_integral + integrating * position_error * dt, -limit, limit)
        acceleration = (reference.acceleration - g["position_kp"] * position_error
                        - g["position_kd"] * velocity_error
                        - g["position_ki"] * self.position_integral)
        force = m * (acceleration + vehicle.gravity * E3)
        w = state.angular_velocity
        thrust, desired, attitude_error, _, r_t_rd = track_thrust_vector(
            force, state.rotation, w, reference, m, vehicle.gravity)
        rate_command = (np.einsum("nij,nj->ni", r_t_rd, desired.angular_velocity)
                        - g["attitude_kp"] * attitude_error)
        rate_error = w - rate_command
        limit = g["rate_integral_limit"]
        self.rate_integral = np.clip(self.rate_integral + integrating * rate_error * dt,
                                     -limit, limit)
        previous = np.where(self.fresh[:, None], rate_error, self.previous_rate_error)
        rate_error_dot = (rate_error - previous) / dt
        self.previous_rate_error, self.fresh[:] = rate_error, False
        angular_acceleration = (np.einsum("nij,nj->ni", r_t_rd, desired.angular_acceleration)
                                - g["rate_kp"] * rate_error - g["rate_ki"] * self.rate_integral
                                - g["rate_kd"] * rate_error_dot)
        moment = cross(w, w @ J.T) + angular_acceleration @ J.T
        self.diagnostics = {"desired_rotation": desired.rotation,
                            "attitude_error": attitude_error, "rate_error": rate_error}
        self._requested = (thrust, moment)
        return thrust, moment

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        requested_thrust, requested_moment = self._requested
        self.saturated = ((np.abs(thrust - requested_thrust) > 1e-9)
                          | np.any(np.abs(moment - requested_moment) > 1e-9, axis=1))

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, **self.gains}
