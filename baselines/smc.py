"""Sliding-mode control on position and attitude, with a boundary layer.

Position: ``s = ev + λ ex``, ``a = ẍd - λ ev - η sat(s/φ)``, ``F = m(a + g e3)``,
``f = F · R e3``, Rd from F and b1d. Attitude (on SO(3), Lee's errors):
``s_R = eΩ + λ_R eR``,
``M = Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) - J(λ_R eΩ + η_R sat(s_R/φ_R))``.
``sat`` clips each component to [-1, 1]: inside the boundary layer the law is linear, so
it does not chatter at 100 Hz; η bounds the disturbance it rejects (η m must exceed
|d_x|). Ωd, Ω̇d are the reference's flat feed-forward.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from baselines.attitude import track_thrust_vector
from baselines.base import E3, Controller, validated_gains
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.so3 import cross, hat
from quad_dob_env.trajectories import Reference

SMC_GAINS = {
    "position_lambda": 2.8, "position_eta": 2.0, "position_boundary": 0.35,
    "attitude_lambda": 8.0, "attitude_eta": 40.0, "attitude_boundary": 1.0,
}


class SlidingModeController(Controller):
    """Sliding-mode control with the gains in ``SMC_GAINS``."""

    name = "smc"

    def __init__(self, **gains: float) -> None:
        super().__init__()
        self.gains = validated_gains("SMC", SMC_GAINS, gains, strictly_positive=True)

    def compute(self, time: NDArray, state: VehicleState,
                reference: Reference) -> tuple[NDArray, NDArray]:
        g, vehicle = self.gains, self.vehicle
        m, J = vehicle.mass, vehicle.inertia_matrix
        position_error = state.position - reference.position
        velocity_error = state.velocity - reference.velocity
        surface = velocity_error + g["position_lambda"] * position_error
        acceleration = (reference.acceleration - g["position_lambda"] * velocity_error
                        - g["position_eta"] * np.clip(surface / g["position_boundary"], -1, 1))
        force = m * (acceleration + vehicle.gravity * E3)
        w = state.angular_velocity
        thrust, desired, attitude_error, rate_error, r_t_rd = track_thrust_vector(
            force, state.rotation, w, reference, m, vehicle.gravity)
        attitude_surface = rate_error + g["attitude_lambda"] * attitude_error
        desired_rate_body = np.einsum("nij,nj->ni", r_t_rd, desired.angular_velocity)
        desired_acceleration_body = np.einsum("nij,nj->ni", r_t_rd,
                                              desired.angular_acceleration)
        correction = (g["attitude_lambda"] * rate_error + g["attitude_eta"]
                      * np.clip(attitude_surface / g["attitude_boundary"], -1, 1))
        moment = (cross(w, w @ J.T)
                  - (np.einsum("nij,nj->ni", hat(w), desired_rate_body)
                     - desired_acceleration_body) @ J.T
                  - correction @ J.T)
        self.diagnostics = {"desired_rotation": desired.rotation,
                            "attitude_error": attitude_error, "sliding_surface": surface}
        return thrust, moment

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, **self.gains}
