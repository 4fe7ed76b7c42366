"""A point-mass payload hanging from the vehicle on a massless cable.

Crazyswarm2's payload flights hang a few grams under a Crazyflie on a string; the cable's
pull on the vehicle depends on where the vehicle is and how it moves, and on the payload's
own swing, which this model integrates itself from the true vehicle state the env hands it
each control step (``Disturbance.follow``).

Model: Sreenath, Lee, Kumar 2013, "Geometric control and differential flatness of a
quadrotor UAV with a cable-suspended load" (CDC), the taut-cable point mass, with the cable
allowed to go slack (no tension while the payload is closer than the cable's length).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.disturbances.base import Disturbance
from quad_dob_env.validation import as_finite

UP = np.array([0.0, 0.0, 1.0])  # e3, world frame (z up)
# a cable this close to its length counts as taut: it absorbs the rounding of the projection
TAUT_TOLERANCE = 1e-9


class SuspendedPayload(Disturbance):
    """A point mass ``mass`` [kg] on a massless cable ``cable_length`` [m] below each vehicle.

    Each control step the env calls ``follow`` with the true vehicle position and velocity
    at the step's start; the model puts the payload back on the cable's sphere, takes the
    cable's tension from the constraint, holds the pull ``T q`` on the vehicle over the
    step (``q`` the unit vector from the vehicle to the payload) and advances the payload by
    one step (semi-implicit Euler). After a reset the payload starts hanging straight down,
    at rest relative to the vehicle.

    ``position``, ``velocity`` (N, 3) are the payload's (world frame, at the next step's
    start after a ``follow``); ``tension`` (N,) is the last step's cable tension [N].
    """

    is_random = True  # per-vehicle state: the env evaluates it every step
    uses_time = False  # the pull is held over the control step
    channels = (True, False, False)
    follows_vehicle = True

    def __init__(self, mass: float, cable_length: float, gravity: float = 9.81) -> None:
        self.mass = as_finite(mass, "SuspendedPayload.mass", 0.0, strictly=True)
        self.cable_length = as_finite(cable_length, "SuspendedPayload.cable_length", 0.0,
                                      strictly=True)
        self.gravity = as_finite(gravity, "SuspendedPayload.gravity", 0.0, strictly=True)
        self.bind(0, 0.0)

    def bind(self, num_vehicles: int, dt: float) -> None:
        self.dt = float(dt)
        self.position = np.zeros((num_vehicles, 3))
        self.velocity = np.zeros((num_vehicles, 3))
        self.tension = np.zeros(num_vehicles)
        self.force = np.zeros((num_vehicles, 3))  # the pull on each vehicle, world frame [N]
        self._vehicle_velocity = np.zeros((num_vehicles, 3))  # at the last follow
        # a vehicle whose payload waits for the vehicle's position to hang below it
        self._unplaced = np.ones(num_vehicles, dtype=np.bool_)

    def resample(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        # nothing random to draw; the vehicles were just placed, so hang the payloads anew
        # at the next follow, when the env hands over where the vehicles are
        self._unplaced[indices] = True
        self.force[indices] = 0.0
        self.tension[indices] = 0.0

    def follow(self, position: ArrayLike, velocity: ArrayLike,
               vehicle_mass: ArrayLike | None = None) -> None:
        vehicle_position = np.asarray(position, dtype=np.float64)
        vehicle_velocity = np.asarray(velocity, dtype=np.float64)
        # 1/M per vehicle; a vehicle moved by hand (None) feels no pull back
        inverse_mass = (np.zeros(len(vehicle_position)) if vehicle_mass is None
                        else 1.0 / np.asarray(vehicle_mass, dtype=np.float64))
        length, g, m, dt = self.cable_length, self.gravity, self.mass, self.dt
        fresh = self._unplaced
        if fresh.any():  # hanging straight down, at rest relative to the vehicle
            self.position[fresh] = vehicle_position[fresh] - length * UP
            self.velocity[fresh] = vehicle_velocity[fresh]
            self._vehicle_velocity[fresh] = vehicle_velocity[fresh]
            # the pull of a payload hanging at rest, as if it had hung there a step already:
            # what the vehicle's last acceleration held
            self.force[fresh] = -m * g * UP
            fresh[:] = False
        # the vehicle's acceleration over the last step (a backward difference: the env
        # hands over states, not forces); zero at the first step after placing
        vehicle_acceleration = (vehicle_velocity - self._vehicle_velocity) / max(dt, 1e-300)
        offset = self.position - vehicle_position
        distance = np.linalg.norm(offset, axis=1)
        direction = offset / np.maximum(distance, 1e-300)[:, None]  # q, vehicle to payload
        relative = self.velocity - vehicle_velocity
        radial = np.einsum("ij,ij->i", direction, relative)
        tangential = relative - radial[:, None] * direction
        tangential_speed_squared = np.einsum("ij,ij->i", tangential, tangential)
        # even a taut cable's payload ends a step a little inside the sphere: by the chord
        # of its swing relative to the vehicle (|v_rel|² dt²/(2L) at most) and by what the
        # semi-implicit step and the vehicle's own integration make of the accelerations
        # (|a| dt²/2 at most). Within that the cable is taut; the bare rounding tolerance
        # would read it slack every other step and the pull would chatter between 0 and 2T
        relative_speed = np.linalg.norm(relative, axis=1)
        acceleration_scale = g + np.linalg.norm(vehicle_acceleration, axis=1)
        slack_margin = (TAUT_TOLERANCE * length + (relative_speed * dt)**2 / length
                        + acceleration_scale * dt**2)
        taut = distance >= length - slack_margin
        # T = m_p (|v_p - v|_⊥²/L - g q·e3 - q·a), from d²/dt² |r_p - x|² = 0 (Sreenath,
        # Lee, Kumar 2013: the load's equation along q). The vehicle's a holds this step's
        # pull, a = a_o + T q / M (the vehicle's equation), so T is solved with it:
        # T (1 + m_p/M) = m_p (|v_p - v|_⊥²/L - g q·e3 - q·a_o), a_o the last step's
        # acceleration less the last step's pull. Read from the backward difference alone,
        # T would ring at the step rate and grow once m_p > M
        other = vehicle_acceleration - self.force * inverse_mass[:, None]
        tension = m * (tangential_speed_squared / length - g * direction[:, 2]
                       - np.einsum("ij,ij->i", direction, other)) / (1.0 + m * inverse_mass)
        # taut-cable constraint |r_p - x| = L (Sreenath, Lee, Kumar 2013, taut-cable model)
        self.position[taut] = vehicle_position[taut] + length * direction[taut]
        # a taut cable cannot stretch: no separating radial velocity. While it pulls
        # (T > 0) the constraint holds at velocity level too, so an approaching radial
        # velocity is the integrator's O(dt²) residue, removed before it builds up into a
        # false slack; a cable that would push (T <= 0) is going slack and keeps it
        pulling = taut & (tension > 0.0)
        held = (taut & (radial > 0.0)) | pulling
        self.velocity[held] -= radial[held, None] * direction[held]
        # a cable pulls, never pushes; a slack one does neither
        self.tension[:] = np.where(pulling, tension, 0.0)
        # the cable's pull on the vehicle, +T q (Sreenath, Lee, Kumar 2013: the vehicle's
        # translational equation)
        self.force[:] = self.tension[:, None] * direction
        # m_p a_p = -m_p g e3 - T q (Sreenath, Lee, Kumar 2013: the load's translational
        # equation), by semi-implicit Euler: the new velocity moves the position
        self.velocity += (-g * UP - self.force / m) * dt
        self.position += self.velocity * dt
        self._vehicle_velocity[:] = vehicle_velocity

    def add_to(self, times: NDArray[np.float64] | None, force: NDArray, torque: NDArray,
               wind: NDArray) -> None:
        # held over the step: the same pull at every sample time
        force += self.force[:, None, :]

    def evaluate(self, times: NDArray[np.float64] | None
                 ) -> tuple[NDArray, NDArray, NDArray]:
        samples = 1 if times is None else np.shape(times)[-1]
        channels = tuple(np.zeros((len(self.force), samples, 3)) for _ in range(3))
        self.add_to(times, *channels)
        return channels

    def __repr__(self) -> str:
        return (f"SuspendedPayload(mass={self.mass:g} kg, cable_length={self.cable_length:g} m, "
                f"gravity={self.gravity:g} m/s²)")
