"""``HoverPD``: a PD position loop and a PD attitude loop on SO(3), written from scratch
against ``quad_dob_baselines.Controller`` as a user would write their own.

The position loop asks for the acceleration ``a = a_d - kx e_x - kv e_v`` (e_x, e_v the
position and velocity errors, e_v on a low-passed velocity), so the thrust vector is
``F = m (a + g e3)``; the vehicle's body z-axis is turned to ``F`` with the reference's
heading, and the collective thrust is ``F`` projected on the current body z-axis.
The attitude loop is a PD on the rotation error ``e_R = ½ vee(Rdᵀ R - Rᵀ Rd)`` with the
gyroscopic term cancelled: ``M = J (-kR e_R - kΩ Ω) + Ω × J Ω``. Unlike Lee et al.'s law it
has no feedforward of the desired rates, no integral and no disturbance estimate: a plain
baseline, to show the interface, not to win.

Gains are per unit mass and inertia (s⁻², s⁻¹), so one set suits any vehicle; all are
declared in ``tunable_gains`` for ``quad-dob tune``, the velocity filter's bandwidth also in
``estimator_bandwidths`` (capped and tie-broken as the built-in observers' rates are).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from quad_dob_baselines import Controller

E3 = np.array([0.0, 0.0, 1.0])


class HoverPD(Controller):
    name = "example-pd"
    # what quad-dob tune searches, and where it starts
    tunable_gains: ClassVar[dict[str, float]] = {
        "kx": 4.0, "kv": 3.0, "kR": 60.0, "kOmega": 12.0, "velocity_bandwidth": 30.0}
    estimator_bandwidths: ClassVar[tuple[str, ...]] = ("velocity_bandwidth",)

    def __init__(self, **gains: float) -> None:
        super().__init__()
        unknown = sorted(set(gains) - set(self.tunable_gains))
        if unknown:
            raise ValueError(f"unknown HoverPD gain {unknown[0]!r}; valid: "
                             + ", ".join(self.tunable_gains))
        self.gains = {**self.tunable_gains, **{k: float(v) for k, v in gains.items()}}
        self.filtered_velocity = np.zeros((0, 3))

    def reset(self, num_vehicles, vehicle, dt, indices=None, actuation="rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if indices is None:
            self.filtered_velocity = np.zeros((self.n, 3))
            self._started = np.zeros(self.n, dtype=bool)
        else:
            self._started[indices] = False  # only these vehicles start again

    def compute(self, time, state, reference):
        g, mass = self.gains, self.vehicle.mass
        # a first-order low-pass on the measured velocity, started at the first reading
        blend = 1.0 - np.exp(-g["velocity_bandwidth"] * self.dt)
        fresh = ~self._started
        self.filtered_velocity[fresh] = state.velocity[fresh]
        self.filtered_velocity += blend * (state.velocity - self.filtered_velocity)
        self._started[:] = True

        position_error = state.position - reference.position
        velocity_error = self.filtered_velocity - reference.velocity
        acceleration = reference.acceleration - g["kx"] * position_error \
            - g["kv"] * velocity_error
        force = mass * (acceleration + self.vehicle.gravity * E3)
        body_z = state.rotation[:, :, 2]
        thrust = np.einsum("ij,ij->i", force, body_z)

        desired_z = force / np.linalg.norm(force, axis=1, keepdims=True)
        desired_y = np.cross(desired_z, reference.heading)
        desired_y /= np.linalg.norm(desired_y, axis=1, keepdims=True)
        desired = np.stack([np.cross(desired_y, desired_z), desired_y, desired_z], axis=2)

        # e_R = ½ vee(Rdᵀ R − Rᵀ Rd), Lee et al. 2010 eq. (10)
        mismatch = np.einsum("nji,njk->nik", desired, state.rotation)
        skew = 0.5 * (mismatch - np.swapaxes(mismatch, 1, 2))
        attitude_error = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=1)
        inertia = self.vehicle.inertia_matrix
        rates = state.angular_velocity
        angular_acceleration = -g["kR"] * attitude_error - g["kOmega"] * rates
        moment = angular_acceleration @ inertia.T + np.cross(rates, rates @ inertia.T)
        self.diagnostics = {"desired_rotation": desired, "attitude_error": attitude_error}
        return thrust, moment

    def describe(self) -> dict:
        return {"name": self.name, **self.gains}
