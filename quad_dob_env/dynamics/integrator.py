"""Equations of motion and their integrator, compiled per vehicle and run over the batch.

Equations (docs/design.md; inertial frame, z up, R maps body to world):
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
from numba import njit
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.dynamics.rotors import (
    lagged_each,
    lagged_output,
    rotor_wrench,
    speed_lag_factors,
    speeds_of_output,
)
from quad_dob_env.params import VehicleParams
from quad_dob_env.so3 import (
    cross_tuple,
    exp_tuple,
    mat_mul_tuple,
    mat_vec_tuple,
    matrix_at,
)


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


class BodyArrays(NamedTuple):
    """Every vehicle's rigid body, so vehicles can differ (randomisation, model tolerance)."""

    mass: NDArray  # (N,) [kg]
    gravity: float  # [m/s²]
    inertia: NDArray  # (N, 3, 3) [kg m²]
    inertia_inverse: NDArray  # (N, 3, 3)
    drag: NDArray  # (N, 6): linear, then quadratic coefficients, body axes


class RigidBody(NamedTuple):
    """One vehicle's rigid body as the equations take it (``vehicle_physics``)."""

    mass: float
    gravity: float
    inertia: tuple  # J, row-major 9-tuple
    inertia_inverse: tuple
    drag_linear: tuple
    drag_quadratic: tuple


class Forcing(NamedTuple):
    """Force, torque and wind velocity on the integrator's sample grid ``t0 + k h / 2``:
    tables shared by all vehicles (rows x samples x 3) plus each vehicle's own part
    (N x samples x 3, the random disturbances)."""

    force: NDArray
    torque: NDArray
    wind: NDArray
    force_own: NDArray
    torque_own: NDArray
    wind_own: NDArray


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


@njit(cache=True, inline="always")
def body_drag(v, rotation, wind, drag_linear, drag_quadratic):
    """Body-frame drag ``-(diag(c1) u + ‖u‖ diag(c2) u)`` on the air-relative velocity
    ``u = Rᵀ(v - w)``: the quadratic term scales with the airspeed, not with each
    component's, so a body that is round in the horizontal plane feels the same drag at
    any heading to the wind (docs/design.md)."""
    r = rotation
    a = (v[0] - wind[0], v[1] - wind[1], v[2] - wind[2])
    u = (r[0] * a[0] + r[3] * a[1] + r[6] * a[2], r[1] * a[0] + r[4] * a[1] + r[7] * a[2],
         r[2] * a[0] + r[5] * a[1] + r[8] * a[2])
    airspeed = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    return (-(drag_linear[0] + drag_quadratic[0] * airspeed) * u[0],
            -(drag_linear[1] + drag_quadratic[1] * airspeed) * u[1],
            -(drag_linear[2] + drag_quadratic[2] * airspeed) * u[2])


@njit(cache=True, inline="always")
def _accelerations(x, v, rotation, omega, thrust, moment, force, torque, wind, body, law,
                   speeds, rotors, thrust_scales):
    """Linear acceleration (world) and angular acceleration (body) of one vehicle (``body``
    a ``RigidBody``); with the rotors' own model on (``rotors.active``) the rotors' wrench
    comes from their ``speeds`` and the air (``quad_dob_env.dynamics.rotors``), else it is
    ``thrust`` and ``moment``."""
    drag = body_drag(v, rotation, wind, body.drag_linear, body.drag_quadratic)
    if rotors.active:
        rotor_force, moment = rotor_wrench(speeds, v, rotation, omega, wind, thrust_scales,
                                           rotors)
        lift = rotor_force[2] * thrust_multiplier_scalar(x[2], law)
        body_force = mat_vec_tuple(rotation, (drag[0] + rotor_force[0],
                                              drag[1] + rotor_force[1], drag[2] + lift))
    else:
        lift = thrust * thrust_multiplier_scalar(x[2], law)
        # m v' = -m g e3 + k f R e3 + R F_drag + d_x  (docs/design.md, with drag as issue 4 adds it)
        body_force = mat_vec_tuple(rotation, (drag[0], drag[1], drag[2] + lift))
    mass = body.mass
    linear = ((body_force[0] + force[0]) / mass, (body_force[1] + force[1]) / mass,
              (body_force[2] + force[2]) / mass - body.gravity)
    # J Ω' = -Ω × JΩ + M + d_Ω  (docs/design.md)
    gyroscopic = cross_tuple(omega, mat_vec_tuple(body.inertia, omega))
    angular = mat_vec_tuple(body.inertia_inverse, (moment[0] + torque[0] - gyroscopic[0],
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
    """Vehicle ``i``'s state as tuples (x, v, R row-major, Ω). Straight-line reads, no view
    (``rotation[i]`` would count a reference)."""
    return ((position[i, 0], position[i, 1], position[i, 2]),
            (velocity[i, 0], velocity[i, 1], velocity[i, 2]),
            (rotation[i, 0, 0], rotation[i, 0, 1], rotation[i, 0, 2], rotation[i, 1, 0],
             rotation[i, 1, 1], rotation[i, 1, 2], rotation[i, 2, 0], rotation[i, 2, 1],
             rotation[i, 2, 2]),
            (angular_velocity[i, 0], angular_velocity[i, 1], angular_velocity[i, 2]))


@njit(cache=True, inline="always")
def store_vehicle(i, position, velocity, rotation, angular_velocity, x, v, R, w):
    """Write vehicle ``i``'s state (x, v, R row-major, Ω), straight-line: an inlined
    function with an array parameter and a loop counts the array in and out at every
    call."""
    position[i, 0], position[i, 1], position[i, 2] = x[0], x[1], x[2]
    velocity[i, 0], velocity[i, 1], velocity[i, 2] = v[0], v[1], v[2]
    angular_velocity[i, 0], angular_velocity[i, 1], angular_velocity[i, 2] = w[0], w[1], w[2]
    rotation[i, 0, 0], rotation[i, 0, 1], rotation[i, 0, 2] = R[0], R[1], R[2]
    rotation[i, 1, 0], rotation[i, 1, 1], rotation[i, 1, 2] = R[3], R[4], R[5]
    rotation[i, 2, 0], rotation[i, 2, 1], rotation[i, 2, 2] = R[6], R[7], R[8]


@njit(cache=True, inline="always")
def sample(table, row, per_vehicle, i, k):
    """Sample k of a time-gridded input: the shared table's row plus vehicle i's own part."""
    return (table[row, k, 0] + per_vehicle[i, k, 0], table[row, k, 1] + per_vehicle[i, k, 1],
            table[row, k, 2] + per_vehicle[i, k, 2])


@njit(cache=True, inline="always")
def lag_factor(elapsed, time_constant):
    """Share of the old actuator output left after ``elapsed`` s (0: no lag)."""
    return math.exp(-elapsed / time_constant) if time_constant > 0.0 else 0.0


@njit(cache=True)
def actuator_wrench(start, command, factor, to_wrench):
    """(f, M) from the actuator output ``command + (start - command) factor``."""
    u0 = command[0] + (start[0] - command[0]) * factor
    u1 = command[1] + (start[1] - command[1]) * factor
    u2 = command[2] + (start[2] - command[2]) * factor
    u3 = command[3] + (start[3] - command[3]) * factor
    w = to_wrench  # 4 rows of 4 (``actuation.as_rows``)
    return (w[0][0] * u0 + w[0][1] * u1 + w[0][2] * u2 + w[0][3] * u3,
            (w[1][0] * u0 + w[1][1] * u1 + w[1][2] * u2 + w[1][3] * u3,
             w[2][0] * u0 + w[2][1] * u1 + w[2][2] * u2 + w[2][3] * u3,
             w[3][0] * u0 + w[3][1] * u1 + w[3][2] * u2 + w[3][3] * u3))


@njit(cache=True, inline="always")
def _stage_actuators(start, command, time_constant, spin_down, to_wrench, elapsed, rotors):
    """Thrust, moment and rotor speeds ``elapsed`` s into the interval (the rotor speeds are
    what the rotors' own model reads, when on; ``spin_down``: their time constant when they
    slow, 0: ``time_constant``)."""
    if rotors.active:
        if rotors.speed_motors and spin_down > 0.0:  # spinning up and down unequally
            output = lagged_each(start, command, speed_lag_factors(
                start, command, time_constant, spin_down, elapsed))
        else:
            output = lagged_output(start, command, lag_factor(elapsed, time_constant))
        return 0.0, (0.0, 0.0, 0.0), speeds_of_output(output, rotors)
    f, m = actuator_wrench(start, command, lag_factor(elapsed, time_constant), to_wrench)
    return f, m, (0.0, 0.0, 0.0, 0.0)


@njit(cache=True, inline="always")
def store_samples(out, g, force, torque, wind):
    """Row g of a tick's forcing samples (``advance_vehicle``'s ``samples``): force,
    torque and wind, 3-tuples, written straight-line."""
    out[g, 0], out[g, 1], out[g, 2] = force[0], force[1], force[2]
    out[g, 3], out[g, 4], out[g, 5] = torque[0], torque[1], torque[2]
    out[g, 6], out[g, 7], out[g, 8] = wind[0], wind[1], wind[2]


@njit(cache=True, inline="always")
def _samples_at(samples, g):
    """Row g of ``samples`` as (force, torque, wind), 3-tuples."""
    return ((samples[g, 0], samples[g, 1], samples[g, 2]),
            (samples[g, 3], samples[g, 4], samples[g, 5]),
            (samples[g, 6], samples[g, 7], samples[g, 8]))


@njit(cache=True)
def advance_vehicle(state, start, command, time_constant, spin_down, to_wrench, samples,
                    body, dt, substeps, law, rotors, thrust_scales):
    """A vehicle from ``state`` (x, v, R, Ω) over ``dt`` in ``substeps`` CF4 steps; returns
    the new (x, v, R, Ω).

    Actuators: their output (rotor thrusts, the wrench, or with speed motors the rotor
    speeds) moves from ``start`` to ``command`` as ``command + (start - command) e^{-t/τ}``
    (exact first-order lag; τ = 0 is instantaneous; speed motors slowing down take
    ``spin_down`` where it is above 0); ``to_wrench`` maps it to (f, M), or
    with the rotors' own model on (``rotors``, ``quad_dob_env.dynamics.rotors``) their
    speeds give the wrench with the air's effect and each rotor's ``thrust_scales``.
    ``samples``: force, torque and wind velocity on the interval's grid ``t0 + k h / 2``
    (``2 substeps + 1`` rows of 9, ``store_samples``), sampled by the caller from the
    ``Forcing`` tables: one array here, where the six tables cost a reference count each
    per call. ``body``: the vehicle's ``RigidBody``.
    """
    x, v, R, w = state
    h = dt / substeps
    for s in range(substeps):
        t0 = s * h
        grid = 2 * s
        f1, m1, u1 = _stage_actuators(start, command, time_constant, spin_down, to_wrench, t0,
                                      rotors)
        f2, m2, u2 = _stage_actuators(start, command, time_constant, spin_down, to_wrench,
                                      t0 + 0.5 * h, rotors)
        f4, m4, u4 = _stage_actuators(start, command, time_constant, spin_down, to_wrench,
                                      t0 + h, rotors)
        d1, t1, w1 = _samples_at(samples, grid)
        d2, t2, w2 = _samples_at(samples, grid + 1)
        d4, t4, w4 = _samples_at(samples, grid + 2)
        a1, al1 = _accelerations(x, v, R, w, f1, m1, d1, t1, w1, body, law, u1, rotors,
                                 thrust_scales)
        x2, v2, om2 = _axpy(h / 2, v, x), _axpy(h / 2, a1, v), _axpy(h / 2, al1, w)
        R2 = mat_mul_tuple(R, exp_tuple((h / 2 * w[0], h / 2 * w[1], h / 2 * w[2])))
        a2, al2 = _accelerations(x2, v2, R2, om2, f2, m2, d2, t2, w2, body, law, u2, rotors,
                                 thrust_scales)
        x3, v3, om3 = _axpy(h / 2, v2, x), _axpy(h / 2, a2, v), _axpy(h / 2, al2, w)
        R3 = mat_mul_tuple(R, exp_tuple((h / 2 * om2[0], h / 2 * om2[1], h / 2 * om2[2])))
        a3, al3 = _accelerations(x3, v3, R3, om3, f2, m2, d2, t2, w2, body, law, u2, rotors,
                                 thrust_scales)
        x4, v4, om4 = _axpy(h, v3, x), _axpy(h, a3, v), _axpy(h, al3, w)
        # CF4 stage 4: Y4 = Y2 exp(h (Ω3 - Ω1 / 2))
        R4 = mat_mul_tuple(R2, exp_tuple(_weighted(h, -0.5, 0.0, 1.0, 0.0, w, om2, om3, w)))
        a4, al4 = _accelerations(x4, v4, R4, om4, f4, m4, d4, t4, w4, body, law, u4, rotors,
                                 thrust_scales)
        # CF4 update: R1 = R0 exp(h(Ω1/4 + Ω2/6 + Ω3/6 - Ω4/12)) exp(h(-Ω1/12 + Ω2/6 + Ω3/6 + Ω4/4))
        first = exp_tuple(_weighted(h, 0.25, 1 / 6, 1 / 6, -1 / 12, w, om2, om3, om4))
        second = exp_tuple(_weighted(h, -1 / 12, 1 / 6, 1 / 6, 0.25, w, om2, om3, om4))
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
def vehicle_physics(i, body):
    """Vehicle i's ``RigidBody`` from the batch's ``BodyArrays``."""
    drag = body.drag
    return RigidBody(body.mass[i], body.gravity, matrix_at(body.inertia, i),
                     matrix_at(body.inertia_inverse, i),
                     (drag[i, 0], drag[i, 1], drag[i, 2]), (drag[i, 3], drag[i, 4], drag[i, 5]))


def physics_arrays(params: VehicleParams, n: int, drag: bool = False,
                   rotor_drag: bool = False) -> BodyArrays:
    """``params``' rigid body for N vehicles; the drag columns are zero unless ``drag``, the
    linear ones also with ``rotor_drag`` (the rotors' own drag, ``dynamics.rotors``,
    replaces them)."""
    linear = np.zeros(3) if rotor_drag else np.asarray(params.drag_linear, dtype=float)
    coefficients = (np.concatenate([linear, params.drag_quadratic]) if drag
                    else np.zeros(6))
    return BodyArrays(
        mass=np.full(n, params.mass), gravity=float(params.gravity),
        inertia=np.broadcast_to(params.inertia_matrix, (n, 3, 3)).copy(),
        inertia_inverse=np.broadcast_to(params.inertia_inverse, (n, 3, 3)).copy(),
        drag=np.broadcast_to(coefficients, (n, 6)).copy())
