"""Equations of motion and their integrator, compiled per vehicle and run over the batch.

Equations (DESIGN.md; inertial frame, z up, R maps body to world):
``x' = v``, ``m v' = -m g e3 + k(h) f R e3 + d_x``, ``R' = R hat(Ω)``,
``J Ω' = -Ω × JΩ + M + d_Ω``, where ``k(h)`` is the in-ground-effect thrust multiplier.

Integration: the commutator-free Lie-group Runge–Kutta method of order 4 (Celledoni,
Marthinsen, Owren 2003, "CF4"): classical RK4 for x, v, Ω and products of exponentials
for R, so R stays on SO(3) to round-off and the whole scheme is fourth order.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.dynamics.state import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.so3 import cross_tuple, exp_tuple, mat_mul_tuple, mat_vec_tuple

# Above this batch size the kernel runs on every core (prange); below, thread start-up
# costs more than it saves.
PARALLEL_MIN_BATCH = 256


class ThrustLaw(NamedTuple):
    """In-ground-effect thrust multiplier ``k(h) = 1 / (1 - coefficient (radius/h)^exponent)``.

    ``h`` is the height above ``floor``, clamped below at ``min_height``; above
    ``cutoff_height`` the multiplier is exactly 1. ``coefficient = 0`` turns it off.
    ``quad_dob_env.disturbances.GroundEffect`` builds these from a model name.
    """

    coefficient: float = 0.0
    exponent: float = 1.0
    radius: float = 1.0
    floor: float = 0.0
    min_height: float = 1.0
    cutoff_height: float = 0.0


NO_GROUND_EFFECT = ThrustLaw()


@njit(cache=True)
def thrust_multiplier_scalar(z: float, law: tuple) -> float:
    coefficient, exponent, radius, floor, min_height, cutoff_height = law
    height = z - floor
    if coefficient == 0.0 or height >= cutoff_height:
        return 1.0
    height = max(height, min_height)
    return 1.0 / (1.0 - coefficient * (radius / height) ** exponent)


@njit(cache=True)
def _thrust_multiplier_batch(z: NDArray, law: tuple, out: NDArray) -> None:
    for i in range(z.shape[0]):
        out[i] = thrust_multiplier_scalar(z[i], law)


def thrust_multiplier(z: ArrayLike, law: ThrustLaw) -> NDArray[np.float64]:
    """``k(h)`` of ``law`` at world heights ``z`` (any shape)."""
    heights = np.asarray(z, dtype=float)
    flat = np.ascontiguousarray(heights.reshape(-1))
    out = np.empty_like(flat)
    _thrust_multiplier_batch(flat, tuple(float(v) for v in law), out)
    return out.reshape(heights.shape)


@njit(cache=True)
def _accelerations(z, rotation, omega, thrust, moment, force, torque, mass, gravity,
                   inertia, inertia_inverse, law):
    """Linear acceleration (world) and angular acceleration (body) of one vehicle."""
    lift = thrust * thrust_multiplier_scalar(z, law) / mass
    # m v' = -m g e3 + k f R e3 + d_x  (DESIGN.md); R e3 is R's third column
    linear = (lift * rotation[2] + force[0] / mass,
              lift * rotation[5] + force[1] / mass,
              lift * rotation[8] + force[2] / mass - gravity)
    # J Ω' = -Ω × JΩ + M + d_Ω  (DESIGN.md)
    gyroscopic = cross_tuple(omega, mat_vec_tuple(inertia, omega))
    angular = mat_vec_tuple(inertia_inverse, (moment[0] + torque[0] - gyroscopic[0],
                                              moment[1] + torque[1] - gyroscopic[1],
                                              moment[2] + torque[2] - gyroscopic[2]))
    return linear, angular


@njit(cache=True, inline="always")
def _axpy(a, x, y):
    return (y[0] + a * x[0], y[1] + a * x[1], y[2] + a * x[2])


@njit(cache=True, inline="always")
def _rk4_sum(y, h, k1, k2, k3, k4):
    return (y[0] + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            y[1] + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            y[2] + h / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]))


@njit(cache=True, inline="always")
def _weighted(h, w1, w2, w3, w4, a, b, c, d):
    return (h * (w1 * a[0] + w2 * b[0] + w3 * c[0] + w4 * d[0]),
            h * (w1 * a[1] + w2 * b[1] + w3 * c[1] + w4 * d[1]),
            h * (w1 * a[2] + w2 * b[2] + w3 * c[2] + w4 * d[2]))


@njit(cache=True, inline="always")
def load_vehicle(i, position, velocity, rotation, angular_velocity):
    """Vehicle ``i``'s state as tuples (x, v, R row-major, Ω)."""
    r = rotation[i]
    return ((position[i, 0], position[i, 1], position[i, 2]),
            (velocity[i, 0], velocity[i, 1], velocity[i, 2]),
            (r[0, 0], r[0, 1], r[0, 2], r[1, 0], r[1, 1], r[1, 2], r[2, 0], r[2, 1], r[2, 2]),
            (angular_velocity[i, 0], angular_velocity[i, 1], angular_velocity[i, 2]))


@njit(cache=True, inline="always")
def store_vehicle(i, position, velocity, rotation, angular_velocity, x, v, R, w):
    for k in range(3):
        position[i, k] = x[k]
        velocity[i, k] = v[k]
        angular_velocity[i, k] = w[k]
    for k in range(9):
        rotation[i, k // 3, k % 3] = R[k]


@njit(cache=True, inline="always")
def _sample(table, row, per_vehicle, i, k):
    """Disturbance sample k: the shared table's row plus vehicle i's own part."""
    return (table[row, k, 0] + per_vehicle[i, k, 0], table[row, k, 1] + per_vehicle[i, k, 1],
            table[row, k, 2] + per_vehicle[i, k, 2])


@njit(cache=True)
def advance_vehicle(x, v, R, w, f, m, force_table, torque_table, row, force_own, torque_own,
                    i, mass, gravity, inertia, inertia_inverse, dt, substeps, law):
    """One vehicle over ``dt`` in ``substeps`` CF4 steps; returns the new (x, v, R, Ω).

    The disturbance at the substep grid ``t0 + k h / 2`` (k = 0 .. 2 substeps) is
    ``force_table[row, k] + force_own[i, k]`` (and likewise for torque): a table shared by
    all vehicles plus each vehicle's own part.
    """
    h = dt / substeps
    for s in range(substeps):
        f_start = _sample(force_table, row, force_own, i, 2 * s)
        f_mid = _sample(force_table, row, force_own, i, 2 * s + 1)
        f_end = _sample(force_table, row, force_own, i, 2 * s + 2)
        t_start = _sample(torque_table, row, torque_own, i, 2 * s)
        t_mid = _sample(torque_table, row, torque_own, i, 2 * s + 1)
        t_end = _sample(torque_table, row, torque_own, i, 2 * s + 2)
        a1, al1 = _accelerations(x[2], R, w, f, m, f_start, t_start, mass, gravity,
                                 inertia, inertia_inverse, law)
        x2, v2, w2 = _axpy(h / 2, v, x), _axpy(h / 2, a1, v), _axpy(h / 2, al1, w)
        R2 = mat_mul_tuple(R, exp_tuple((h / 2 * w[0], h / 2 * w[1], h / 2 * w[2])))
        a2, al2 = _accelerations(x2[2], R2, w2, f, m, f_mid, t_mid, mass, gravity,
                                 inertia, inertia_inverse, law)
        x3, v3, w3 = _axpy(h / 2, v2, x), _axpy(h / 2, a2, v), _axpy(h / 2, al2, w)
        R3 = mat_mul_tuple(R, exp_tuple((h / 2 * w2[0], h / 2 * w2[1], h / 2 * w2[2])))
        a3, al3 = _accelerations(x3[2], R3, w3, f, m, f_mid, t_mid, mass, gravity,
                                 inertia, inertia_inverse, law)
        x4, v4, w4 = _axpy(h, v3, x), _axpy(h, a3, v), _axpy(h, al3, w)
        # CF4 stage 4: Y4 = Y2 exp(h (Ω3 - Ω1 / 2))
        R4 = mat_mul_tuple(R2, exp_tuple(_weighted(h, -0.5, 0.0, 1.0, 0.0, w, w2, w3, w)))
        a4, al4 = _accelerations(x4[2], R4, w4, f, m, f_end, t_end, mass, gravity,
                                 inertia, inertia_inverse, law)
        # CF4 update: R1 = R0 exp(h(Ω1/4 + Ω2/6 + Ω3/6 - Ω4/12)) exp(h(-Ω1/12 + Ω2/6 + Ω3/6 + Ω4/4))
        first = exp_tuple(_weighted(h, 0.25, 1 / 6, 1 / 6, -1 / 12, w, w2, w3, w4))
        second = exp_tuple(_weighted(h, -1 / 12, 1 / 6, 1 / 6, 0.25, w, w2, w3, w4))
        R = mat_mul_tuple(mat_mul_tuple(R, first), second)
        x = _rk4_sum(x, h, v, v2, v3, v4)
        v = _rk4_sum(v, h, a1, a2, a3, a4)
        w = _rk4_sum(w, h, al1, al2, al3, al4)
    return x, v, R, w


@njit(cache=True, inline="always")
def all_finite(x, v, R, w) -> bool:
    total = x[0] + x[1] + x[2] + v[0] + v[1] + v[2] + w[0] + w[1] + w[2]
    for k in range(9):
        total += R[k]
    return math.isfinite(total)


@njit(cache=True, inline="always")
def matrix_tuple(a):
    """A 3x3 array as a row-major 9-tuple."""
    return (a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2], a[2, 0], a[2, 1], a[2, 2])


def _integrate_kernel(position, velocity, rotation, angular_velocity, thrust, moment,
                      force_table, torque_table, force_own, torque_own, mass, gravity,
                      inertia_array, inertia_inverse_array, dt, substeps, law, diverged):
    """Advance every vehicle in place; a vehicle whose new state is not finite keeps its
    old state and is flagged in ``diverged``."""
    inertia, inertia_inverse = matrix_tuple(inertia_array), matrix_tuple(inertia_inverse_array)
    for i in prange(position.shape[0]):
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        m = (moment[i, 0], moment[i, 1], moment[i, 2])
        x, v, R, w = advance_vehicle(x, v, R, w, thrust[i], m, force_table, torque_table, 0,
                                     force_own, torque_own, i, mass, gravity, inertia,
                                     inertia_inverse, dt, substeps, law)
        diverged[i] = not all_finite(x, v, R, w)
        if not diverged[i]:
            store_vehicle(i, position, velocity, rotation, angular_velocity, x, v, R, w)


# One equation source, compiled twice: serial for small batches, threaded for large ones.
_integrate_serial = njit(cache=True)(_integrate_kernel)
_integrate_parallel = njit(cache=True, parallel=True)(_integrate_kernel)


@njit(cache=True)
def _derivative_batch(state_z, rotation, omega, thrust, moment, force, torque, mass, gravity,
                      inertia_array, inertia_inverse_array, law, linear_out, angular_out):
    inertia, inertia_inverse = matrix_tuple(inertia_array), matrix_tuple(inertia_inverse_array)
    for i in range(state_z.shape[0]):
        linear, angular = _accelerations(
            state_z[i], matrix_tuple(rotation[i]),
            (omega[i, 0], omega[i, 1], omega[i, 2]), thrust[i],
            (moment[i, 0], moment[i, 1], moment[i, 2]),
            (force[i, 0], force[i, 1], force[i, 2]), (torque[i, 0], torque[i, 1], torque[i, 2]),
            mass, gravity, inertia, inertia_inverse, law)
        for k in range(3):
            linear_out[i, k] = linear[k]
            angular_out[i, k] = angular[k]


def accelerations(state: VehicleState, thrust: ArrayLike, moment: ArrayLike,
                  params: VehicleParams, force: ArrayLike | None = None,
                  torque: ArrayLike | None = None, law: ThrustLaw = NO_GROUND_EFFECT,
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(v', Ω')`` for the batch: linear acceleration (world) and angular (body)."""
    n = state.n
    zeros = np.zeros((n, 3))
    linear, angular = np.empty((n, 3)), np.empty((n, 3))
    _derivative_batch(
        np.ascontiguousarray(state.position[:, 2]), state.rotation, state.angular_velocity,
        np.broadcast_to(np.asarray(thrust, float), (n,)).copy(),
        np.broadcast_to(np.asarray(moment, float), (n, 3)).copy(),
        zeros if force is None else np.broadcast_to(np.asarray(force, float), (n, 3)).copy(),
        zeros if torque is None else np.broadcast_to(np.asarray(torque, float), (n, 3)).copy(),
        params.mass, params.gravity, params.inertia_matrix, params.inertia_inverse,
        tuple(float(v) for v in law), linear, angular)
    return linear, angular


def integrate(state: VehicleState, thrust: NDArray, moment: NDArray, params: VehicleParams,
              dt: float, substeps: int = 1, force_samples: NDArray | None = None,
              torque_samples: NDArray | None = None, law: ThrustLaw = NO_GROUND_EFFECT,
              ) -> NDArray[np.bool_]:
    """Advance ``state`` in place by ``dt`` with thrust and moment held constant.

    ``force_samples`` / ``torque_samples`` (N, 2*substeps+1, 3) give the external force
    (world) and torque (body) at the times ``t0 + k dt / (2 substeps)``; None means zero.
    Returns the mask of vehicles whose step diverged (they keep their old state).
    """
    n = state.n
    samples = 2 * substeps + 1
    zeros = None
    if force_samples is None or torque_samples is None:
        zeros = np.zeros((n, samples, 3))
    force_samples = zeros if force_samples is None else force_samples
    torque_samples = zeros if torque_samples is None else torque_samples
    if force_samples.shape != (n, samples, 3) or torque_samples.shape != (n, samples, 3):
        raise ValueError(
            f"disturbance samples must have shape (N={n}, 2*substeps+1={samples}, 3), got "
            f"{force_samples.shape} and {torque_samples.shape}"
        )
    diverged = np.zeros(n, dtype=np.bool_)
    kernel = _integrate_parallel if n >= PARALLEL_MIN_BATCH else _integrate_serial
    no_table = np.zeros((1, samples, 3))
    kernel(state.position, state.velocity, state.rotation, state.angular_velocity,
           np.ascontiguousarray(thrust, dtype=float), np.ascontiguousarray(moment, dtype=float),
           no_table, no_table, np.ascontiguousarray(force_samples),
           np.ascontiguousarray(torque_samples), params.mass, params.gravity, params.inertia_matrix,
           params.inertia_inverse, float(dt), int(substeps), tuple(float(v) for v in law),
           diverged)
    return diverged


