"""Desired attitude from a thrust vector and a heading, with analytic Ωd and Ω̇d.

Lee, Leok, McClamroch 2010 (z up): ``b3d = F/|F|``, ``b2d = b3d × b1d / |b3d × b1d|``,
``Rd = [b2d × b3d, b2d, b3d]``. Given F and b1d with their first two time derivatives, every
column's derivatives follow by the product rule, and
``Ωd = vee(Rdᵀ Ṙd)``, ``Ω̇d = vee(Rdᵀ R̈d - hat(Ωd)²)`` (from ``Ṙd = Rd hat(Ωd)``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.so3 import cross, hat, vee

_TINY = 1e-9  # norms below this are floored so a degenerate command never yields NaN


def _dot(a: NDArray, b: NDArray) -> NDArray:
    return np.einsum("ni,ni->n", a, b)[:, None]


def unit_vector_derivatives(a: NDArray, a_dot: NDArray, a_ddot: NDArray
                            ) -> tuple[NDArray, NDArray, NDArray]:
    """``u = a/|a|`` and its first two time derivatives, for (N, 3) arrays."""
    norm = np.maximum(np.linalg.norm(a, axis=1, keepdims=True), _TINY)
    u = a / norm
    a_adot = _dot(a, a_dot)
    u_dot = a_dot / norm - a * a_adot / norm**3
    u_ddot = (a_ddot / norm - 2 * a_dot * a_adot / norm**3
              - a * (_dot(a_dot, a_dot) + _dot(a, a_ddot)) / norm**3
              + 3 * a * a_adot**2 / norm**5)
    return u, u_dot, u_ddot


class DesiredAttitude(NamedTuple):
    rotation: NDArray  # Rd (N, 3, 3)
    angular_velocity: NDArray  # Ωd (N, 3), body frame of Rd
    angular_acceleration: NDArray  # Ω̇d (N, 3)


def desired_attitude(force: NDArray, force_dot: NDArray, force_ddot: NDArray,
                     heading: NDArray, heading_rate: NDArray,
                     heading_acceleration: NDArray) -> DesiredAttitude:
    """Rd, Ωd, Ω̇d from the desired thrust vector F and heading b1d (each (N, 3))."""
    b3, b3_dot, b3_ddot = unit_vector_derivatives(force, force_dot, force_ddot)
    c = cross(b3, heading)
    c_dot = cross(b3_dot, heading) + cross(b3, heading_rate)
    c_ddot = (cross(b3_ddot, heading) + 2 * cross(b3_dot, heading_rate)
              + cross(b3, heading_acceleration))
    b2, b2_dot, b2_ddot = unit_vector_derivatives(c, c_dot, c_ddot)
    b1 = cross(b2, b3)
    b1_dot = cross(b2_dot, b3) + cross(b2, b3_dot)
    b1_ddot = cross(b2_ddot, b3) + 2 * cross(b2_dot, b3_dot) + cross(b2, b3_ddot)
    rd = np.stack([b1, b2, b3], axis=-1)
    rd_dot = np.stack([b1_dot, b2_dot, b3_dot], axis=-1)
    rd_ddot = np.stack([b1_ddot, b2_ddot, b3_ddot], axis=-1)
    rd_t = np.swapaxes(rd, 1, 2)
    omega = vee(rd_t @ rd_dot)
    omega_hat = hat(omega)
    omega_dot = vee(rd_t @ rd_ddot - omega_hat @ omega_hat)
    return DesiredAttitude(rd, omega, omega_dot)


def attitude_errors(rotation: NDArray, angular_velocity: NDArray,
                    desired: DesiredAttitude) -> tuple[NDArray, NDArray, NDArray]:
    """``eR = ½ vee(RdᵀR - RᵀRd)``, ``eΩ = Ω - RᵀRd Ωd`` (Lee 2010), and ``RᵀRd``."""
    rd = desired.rotation
    rd_t_r = np.swapaxes(rd, 1, 2) @ rotation
    attitude_error = 0.5 * vee(rd_t_r - np.swapaxes(rd_t_r, 1, 2))
    r_t_rd = np.swapaxes(rd_t_r, 1, 2)
    rate_error = angular_velocity - np.einsum("nij,nj->ni", r_t_rd, desired.angular_velocity)
    return attitude_error, rate_error, r_t_rd


def body_z_rate(rotation: NDArray, angular_velocity: NDArray) -> NDArray:
    """d/dt (R e3) = R hat(Ω) e3 = R [Ω_y, -Ω_x, 0]."""
    w = angular_velocity
    return np.einsum("nij,nj->ni", rotation,
                     np.stack([w[:, 1], -w[:, 0], np.zeros(len(w))], axis=1))


def feedforward_attitude(reference, mass: float, gravity: float) -> DesiredAttitude:
    """The attitude that flies the reference exactly (differential flatness): F = m(ẍd + g e3),
    with its derivatives m x⃛d and m x⃜d. Baselines without a model-based F use its Ωd, Ω̇d."""
    force = mass * reference.acceleration
    force[:, 2] += mass * gravity
    return desired_attitude(force, mass * reference.jerk, mass * reference.snap,
                            reference.heading, reference.heading_rate,
                            reference.heading_acceleration)


def attitude_towards(force: NDArray, heading: NDArray) -> NDArray:
    """Rd for thrust direction ``force`` and heading b1d (no derivatives needed)."""
    zeros = np.zeros_like(force)
    return desired_attitude(force, zeros, zeros, heading, zeros, zeros).rotation


class ThrustVectorTracking(NamedTuple):
    thrust: NDArray  # (N,) f = F · R e3
    desired: DesiredAttitude  # Rd towards F, with the reference's flat Ωd, Ω̇d
    attitude_error: NDArray  # eR
    rate_error: NDArray  # eΩ
    r_t_rd: NDArray  # RᵀRd


def track_thrust_vector(force: NDArray, rotation: NDArray, angular_velocity: NDArray,
                        reference, mass: float, gravity: float) -> ThrustVectorTracking:
    """For baselines that choose a thrust vector F without a model of its derivatives:
    collective thrust, Rd towards F with flat feed-forward rates, and Lee's errors."""
    thrust = np.einsum("ni,ni->n", force, rotation[:, :, 2])
    feedforward = feedforward_attitude(reference, mass, gravity)
    desired = feedforward._replace(rotation=attitude_towards(force, reference.heading))
    attitude_error, rate_error, r_t_rd = attitude_errors(rotation, angular_velocity, desired)
    return ThrustVectorTracking(thrust, desired, attitude_error, rate_error, r_t_rd)
