"""Desired attitude from a thrust vector and a heading, with analytic Ωd and Ω̇d, for batches.

The equations (Lee, Leok, McClamroch 2010, z up) live once, per vehicle: Rd, Ωd, Ω̇d in
``quad_dob_env.flatness`` (which the scenarios' feasibility check uses too), Lee's errors in
``quad_dob_baselines.geometric_kernels``; these are their (N, 3) numpy faces for the baselines.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from quad_dob_baselines import geometric_kernels as kernels
from quad_dob_env.flatness import DesiredAttitude, attitude_from_thrust_vector, flat_attitude


def _c(array: NDArray) -> NDArray[np.float64]:
    return np.ascontiguousarray(array, dtype=np.float64)


def attitude_errors(rotation: NDArray, angular_velocity: NDArray,
                    desired: DesiredAttitude) -> tuple[NDArray, NDArray, NDArray]:
    """``eR = ½ vee(RdᵀR - RᵀRd)``, ``eΩ = Ω - RᵀRd Ωd`` (Lee 2010), and ``RᵀRd``."""
    n = len(rotation)
    attitude_error, rate_error, r_t_rd = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3, 3))
    kernels.attitude_errors_batch(_c(rotation), _c(angular_velocity), _c(desired.rotation),
                                  _c(desired.angular_velocity), attitude_error, rate_error,
                                  r_t_rd)
    return attitude_error, rate_error, r_t_rd


def attitude_towards(force: NDArray, heading: NDArray) -> NDArray:
    """Rd for thrust direction ``force`` and heading b1d (no derivatives needed)."""
    zeros = np.zeros_like(force)
    return attitude_from_thrust_vector(force, zeros, zeros, heading, zeros, zeros).rotation


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
    # baselines without a model of F's derivatives use the reference's flat Ωd, Ω̇d
    feedforward = flat_attitude(reference, mass, gravity)
    desired = feedforward._replace(rotation=attitude_towards(force, reference.heading))
    attitude_error, rate_error, r_t_rd = attitude_errors(rotation, angular_velocity, desired)
    return ThrustVectorTracking(thrust, desired, attitude_error, rate_error, r_t_rd)
