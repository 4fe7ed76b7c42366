"""Cascaded PID: position PID -> desired thrust vector and attitude; attitude P -> rate
command; rate PID -> body moment.

Anti-windup, per axis, by conditional integration (Åström & Hägglund, *Advanced PID
Control*, 2006, §3.5): an integrator axis stops only while the mixer clipped the command
that axis drives *and* integrating would push that command further into its limit. The
position integrator drives the collective thrust (its increment ``-m Ki ex dt`` changes
``f`` by ``-m Ki (ex ⊙ b3) dt``); the rate integrator drives each body moment. "Clipped" is
the vehicle's own mixer applied to the PID's request (``Actuator``), not the lagged motor
output, and a yaw the rotors cannot make leaves the position and roll/pitch integrators
running. Both integrators are also clamped.

Outer: ``a = ẍd - Kp ex - Kd ev - Ki ∫ex``, ``F = m (a + g e3)``, ``f = F · R e3``, Rd from
F and b1d. Middle: ``ω_cmd = RᵀRd Ωd_ff - K_att eR``. Inner: ``e_ω = Ω - ω_cmd``,
``M = Ω × JΩ + J (RᵀRd Ω̇d_ff - K_ω e_ω - K_ωi ∫e_ω - K_ωd ė_ω)``, ė_ω by backward difference.
Ωd_ff, Ω̇d_ff are the reference's flat feed-forward (``quad_dob_env.flatness.flat_attitude``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_baselines.attitude import track_thrust_vector
from quad_dob_baselines.base import E3, Controller, validated_gains
from quad_dob_baselines.inner import PID, InnerLaw, inner_law
from quad_dob_env.dynamics import Actuator, VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.so3 import cross
from quad_dob_env.trajectories import Reference

# Chosen by `quad-dob tune` (training/tuning/tune.py: coordinate descent on seeds 100-109 of the
# v1 wind scenarios) from the hand-set start kp 16, kd 6, ki 6, attitude 10, rate 25 / 20 /
# 0.3: objective 0.0454 m -> 0.0268 m. The integral limits are clamps, not searched.
PID_GAINS = {
    "position_kp": 22.4, "position_kd": 6.0, "position_ki": 24.0,
    "position_integral_limit": 0.3, "attitude_kp": 10.0, "rate_kp": 35.0, "rate_ki": 80.0,
    "rate_kd": 0.3, "rate_integral_limit": 0.2,
}


class CascadedPID(Controller):
    """Cascaded PID with the gains in ``PID_GAINS`` (1/s units, scaled by m and J)."""

    name = "pid"

    def __init__(self, **gains: float) -> None:
        super().__init__()
        self.gains = validated_gains("PID", PID_GAINS, gains, strictly_positive=False)

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if indices is None:
            self.mixer = Actuator(vehicle, actuation)
            self.position_integral = np.zeros((num_vehicles, 3))
            self.rate_integral = np.zeros((num_vehicles, 3))
            self.previous_rate_error = np.zeros((num_vehicles, 3))
            # requested minus what the mixer made of it: > 0 clipped from above
            self.thrust_excess = np.zeros(num_vehicles)
            self.moment_excess = np.zeros((num_vehicles, 3))
            self.fresh = np.ones(num_vehicles, dtype=bool)
        else:
            for array in (self.position_integral, self.rate_integral, self.previous_rate_error,
                          self.thrust_excess, self.moment_excess):
                array[indices] = 0.0
            self.fresh[indices] = True

    def compute(self, time: NDArray, state: VehicleState,
                reference: Reference) -> tuple[NDArray, NDArray]:
        g, vehicle, dt = self.gains, self.vehicle, self.dt
        m, J = vehicle.mass, vehicle.inertia_matrix
        position_error = state.position - reference.position
        velocity_error = state.velocity - reference.velocity
        body_z = state.rotation[:, :, 2]
        # an axis whose increment would raise a thrust clipped from above (or lower one
        # clipped from below) waits: its share of the change of f is -m Ki ex_k b3_k dt
        winding = self.thrust_excess[:, None] * (-position_error * body_z) > 0
        limit = g["position_integral_limit"]
        self.position_integral = np.clip(
            self.position_integral + ~winding * position_error * dt, -limit, limit)
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
        # each moment axis alone: its increment changes M by -J Kωi eω dt
        winding = self.moment_excess * -(rate_error @ J.T) > 0
        limit = g["rate_integral_limit"]
        rate_integral = np.clip(self.rate_integral + ~winding * rate_error * dt, -limit, limit)
        previous = np.where(self.fresh[:, None], rate_error, self.previous_rate_error)
        if self.inner_period is None:
            self.rate_integral = rate_integral
            self.previous_rate_error, self.fresh[:] = rate_error, False
        # else the inner loop runs the rate loop and keeps its state (``inner``); this
        # step-start moment is what the anti-windup of the position loop reads
        rate_error_dot = (rate_error - previous) / dt
        angular_acceleration = (np.einsum("nij,nj->ni", r_t_rd, desired.angular_acceleration)
                                - g["rate_kp"] * rate_error - g["rate_ki"] * rate_integral
                                - g["rate_kd"] * rate_error_dot)
        moment = cross(w, w @ J.T) + angular_acceleration @ J.T
        self.diagnostics = {"desired_rotation": desired.rotation,
                            "attitude_error": attitude_error, "rate_error": rate_error,
                            "desired_force": force,
                            "desired_angular_velocity": desired.angular_velocity,
                            "desired_angular_acceleration": desired.angular_acceleration}
        self._requested = (thrust, moment)
        return thrust, moment

    has_inner_law = True

    def inner_law(self) -> InnerLaw:
        """Attitude P and rate PID at the inner rate, its integrator kept here."""
        g = self.gains
        gains = np.array([[g["attitude_kp"]], [g["rate_kp"]], [g["rate_ki"]], [g["rate_kd"]],
                          [g["rate_integral_limit"]]]) * np.ones(3)
        n = len(self.diagnostics["desired_force"])
        return inner_law(PID, gains, self.vehicle.inertia_matrix, self.diagnostics, n,
                         pid_state=(self.rate_integral, self.previous_rate_error, self.fresh,
                                    self.moment_excess))

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        """The anti-windup reads the mixer's clipping of the PID's own request, which is
        what integrating can influence; the (lagged) applied output is not needed."""
        requested_thrust, requested_moment = self._requested
        mixed = self.mixer.apply(requested_thrust, requested_moment)
        self.thrust_excess = requested_thrust - mixed.thrust
        # rounding in the mixer's round trip is not saturation
        self.thrust_excess[np.abs(self.thrust_excess) < 1e-9] = 0.0
        if self.inner_period is None:  # else the inner loop keeps it, tick by tick
            self.moment_excess = requested_moment - mixed.moment
            self.moment_excess[np.abs(self.moment_excess) < 1e-9] = 0.0

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, **self.gains}
