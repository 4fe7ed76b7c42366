"""Differential flatness: the attitude, body rates and inputs that fly a reference exactly.

A quadrotor's position and heading are flat outputs (Mellinger & Kumar 2011): from the
thrust vector ``F = m(ẍd + g e3)`` and its derivatives (``m x⃛d``, ``m x⃜d``) and the heading
b1d with its derivatives follow Rd, Ωd, Ω̇d (Lee, Leok, McClamroch 2010, z up) and the
moment an ideal vehicle needs without disturbance, ``M = J Ω̇d + Ωd × J Ωd``. The same
``desired_attitude`` gives the geometric controller its Rd, Ωd, Ω̇d from its own F, so the
equation is written once, here, below both the scenarios (which check their references
against the actuators with it) and the controllers.

Vectors are 3-tuples and matrices row-major 9-tuples, as in ``quad_dob_env.so3``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.so3 import cross_tuple

TINY = 1e-9  # norms below this are floored so a degenerate command never yields NaN


@njit(cache=True, inline="always")
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, inline="always")
def combine(a, x, b, y):
    """``a x + b y`` for scalars a, b and 3-tuples x, y."""
    return (a * x[0] + b * y[0], a * x[1] + b * y[1], a * x[2] + b * y[2])


@njit(cache=True, inline="always")
def add(x, y):
    return (x[0] + y[0], x[1] + y[1], x[2] + y[2])


@njit(cache=True)
def unit_vector_derivatives(a, a_dot, a_ddot):
    """``u = a/|a|`` and its first two time derivatives (product rule)."""
    norm = max(math.sqrt(dot(a, a)), TINY)
    a_adot = dot(a, a_dot)
    first = a_adot / norm**3
    # d²/dt² (a/|a|) = ä/|a| - 2 ȧ (a·ȧ)/|a|³ - a ((ȧ·ȧ + a·ä)/|a|³ - 3 (a·ȧ)²/|a|⁵)
    second = (dot(a_dot, a_dot) + dot(a, a_ddot)) / norm**3 - 3.0 * a_adot**2 / norm**5
    u = (a[0] / norm, a[1] / norm, a[2] / norm)
    u_dot = (a_dot[0] / norm - a[0] * first, a_dot[1] / norm - a[1] * first,
             a_dot[2] / norm - a[2] * first)
    u_ddot = (a_ddot[0] / norm - 2.0 * a_dot[0] * first - a[0] * second,
              a_ddot[1] / norm - 2.0 * a_dot[1] * first - a[1] * second,
              a_ddot[2] / norm - 2.0 * a_dot[2] * first - a[2] * second)
    return u, u_dot, u_ddot


@njit(cache=True)
def desired_attitude(force, force_dot, force_ddot, heading, heading_rate, heading_acceleration):
    """Rd, Ωd, Ω̇d from the thrust vector F and heading b1d with their derivatives.

    Lee 2010 (z up): ``b3d = F/|F|``, ``b2d = b3d × b1d/|b3d × b1d|``, ``b1d' = b2d × b3d``;
    ``Ωd = vee(RdᵀṘd)`` and ``Ω̇d = vee(RdᵀR̈d - hat(Ωd)²)``, where hat(Ωd)² is symmetric
    and drops out, so ``(RdᵀṘd)_ij = b_i · ḃ_j`` gives both.
    """
    b3, b3_dot, b3_ddot = unit_vector_derivatives(force, force_dot, force_ddot)
    c = cross_tuple(b3, heading)
    c_dot = add(cross_tuple(b3_dot, heading), cross_tuple(b3, heading_rate))
    c_ddot = add(combine(1.0, cross_tuple(b3_ddot, heading), 2.0,
                         cross_tuple(b3_dot, heading_rate)),
                 cross_tuple(b3, heading_acceleration))
    b2, b2_dot, b2_ddot = unit_vector_derivatives(c, c_dot, c_ddot)
    b1 = cross_tuple(b2, b3)
    b1_dot = add(cross_tuple(b2_dot, b3), cross_tuple(b2, b3_dot))
    b1_ddot = add(combine(1.0, cross_tuple(b2_ddot, b3), 2.0, cross_tuple(b2_dot, b3_dot)),
                  cross_tuple(b2, b3_ddot))
    rotation = (b1[0], b2[0], b3[0], b1[1], b2[1], b3[1], b1[2], b2[2], b3[2])
    # vee(S) = ½ (S₃₂ - S₂₃, S₁₃ - S₃₁, S₂₁ - S₁₂)
    rate = (0.5 * (dot(b3, b2_dot) - dot(b2, b3_dot)), 0.5 * (dot(b1, b3_dot) - dot(b3, b1_dot)),
            0.5 * (dot(b2, b1_dot) - dot(b1, b2_dot)))
    acceleration = (0.5 * (dot(b3, b2_ddot) - dot(b2, b3_ddot)),
                    0.5 * (dot(b1, b3_ddot) - dot(b3, b1_ddot)),
                    0.5 * (dot(b2, b1_ddot) - dot(b1, b2_ddot)))
    return rotation, rate, acceleration


@njit(cache=True)
def desired_attitude_batch(force, force_dot, force_ddot, heading, heading_rate,
                           heading_acceleration, rotation, rate, acceleration):
    for i in range(force.shape[0]):
        rd, rate_d, acceleration_d = desired_attitude(
            (force[i, 0], force[i, 1], force[i, 2]),
            (force_dot[i, 0], force_dot[i, 1], force_dot[i, 2]),
            (force_ddot[i, 0], force_ddot[i, 1], force_ddot[i, 2]),
            (heading[i, 0], heading[i, 1], heading[i, 2]),
            (heading_rate[i, 0], heading_rate[i, 1], heading_rate[i, 2]),
            (heading_acceleration[i, 0], heading_acceleration[i, 1],
             heading_acceleration[i, 2]))
        for k in range(9):
            rotation[i, k // 3, k % 3] = rd[k]
        for k in range(3):
            rate[i, k] = rate_d[k]
            acceleration[i, k] = acceleration_d[k]


class DesiredAttitude(NamedTuple):
    rotation: NDArray  # Rd (N, 3, 3)
    angular_velocity: NDArray  # Ωd (N, 3), body frame of Rd
    angular_acceleration: NDArray  # Ω̇d (N, 3)


def _c(array: NDArray) -> NDArray[np.float64]:
    return np.ascontiguousarray(array, dtype=np.float64)


def attitude_from_thrust_vector(force: NDArray, force_dot: NDArray, force_ddot: NDArray,
                                heading: NDArray, heading_rate: NDArray,
                                heading_acceleration: NDArray) -> DesiredAttitude:
    """Rd, Ωd, Ω̇d from the thrust vector F and heading b1d (each (N, 3)) and their first
    two time derivatives (``desired_attitude`` for a batch)."""
    n = len(force)
    out = DesiredAttitude(np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3)))
    desired_attitude_batch(_c(force), _c(force_dot), _c(force_ddot), _c(heading),
                           _c(heading_rate), _c(heading_acceleration), *out)
    return out


class FlatInputs(NamedTuple):
    """What an ideal vehicle without disturbance needs to fly a reference, per sample."""

    thrust: NDArray  # (T,) collective thrust f = m ‖ẍd + g e3‖ [N]
    moment: NDArray  # (T, 3) body moment M = J Ω̇d + Ωd × J Ωd [N m]
    body_rate: NDArray  # (T, 3) Ωd [rad/s]
    attitude: DesiredAttitude


def flat_attitude(reference, mass: float, gravity: float) -> DesiredAttitude:
    """Rd, Ωd, Ω̇d that fly ``reference`` (a ``Reference`` of T samples) exactly: the thrust
    vector F = m(ẍd + g e3) with its derivatives m x⃛d and m x⃜d, and the heading."""
    force = mass * np.asarray(reference.acceleration, dtype=float)
    force[:, 2] += mass * gravity
    return attitude_from_thrust_vector(
        force, mass * reference.jerk, mass * reference.snap, reference.heading,
        reference.heading_rate, reference.heading_acceleration)


def flat_inputs(reference, mass: float, gravity: float,
                inertia: NDArray) -> FlatInputs:
    """The thrust, moment and body rates that fly ``reference`` (a ``Reference`` of T
    samples) exactly, by differential flatness."""
    attitude = flat_attitude(reference, mass, gravity)
    rate, rate_dot = attitude.angular_velocity, attitude.angular_acceleration
    inertia = np.asarray(inertia, dtype=float)
    # M = J Ω̇d + Ωd × J Ωd (Euler's equation with no disturbance)
    moment = rate_dot @ inertia.T + np.cross(rate, rate @ inertia.T)
    # f = F · b3d = ‖F‖ = m ‖ẍd + g e3‖
    thrust = mass * np.linalg.norm(reference.acceleration + np.array([0.0, 0.0, gravity]),
                                   axis=1)
    return FlatInputs(thrust, moment, rate, attitude)
