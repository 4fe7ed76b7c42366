"""The geometric controller's and the observer's equations, once, per vehicle, compiled.

These functions are the one source of truth for the equations: ``attitude``, ``geometric``
and ``observer`` call the batch loops at the bottom, which numba compiles (the geometric
loop is split across cores by ``quad_dob_env.threads``); Rd, Ωd, Ω̇d come from
``quad_dob_env.flatness``. ``tests/test_oracle.py`` holds them to an independent plain-numpy
oracle written from docs/design.md's equations. Compiled because the numpy version spent ~200
small array operations per step and held a 4096-vehicle vector env with the base in the
loop to 430,000 env-steps/s.

Vectors are 3-tuples and matrices row-major 9-tuples, as in ``quad_dob_env.so3``. The
kernels read their records by name: ``ReferenceVectors`` (the reference's eight vectors),
``GeometricLaw`` (the law's constants) and ``GeometricOutputs`` (the arrays it writes). From
Python they are passed as plain tuples (``tuple(record)``: numba types a named tuple on a
slower path every call) and rebuilt in the kernel's first line; between compiled functions
the named tuple itself is passed.
"""

from __future__ import annotations

from typing import NamedTuple

from numba import njit
from numpy.typing import NDArray

from quad_dob_env.flatness import add, combine, desired_attitude, dot
from quad_dob_env.so3 import (
    cross_tuple,
    mat_mul_tuple,
    mat_vec_tuple,
    matrix_at,
    matrix_entries,
    store_matrix,
    store_vector,
    transpose_tuple,
    vector_at,
)


class ReferenceVectors(NamedTuple):
    """The reference's eight vectors (``quad_dob_env.trajectories.Reference``'s order): for
    one vehicle 3-tuples, for a batch (N, 3) arrays."""

    position: tuple
    velocity: tuple
    acceleration: tuple
    jerk: tuple
    snap: tuple
    heading: tuple  # b1d
    heading_rate: tuple
    heading_acceleration: tuple


class GeometricLaw(NamedTuple):
    """Lee's law's constants, in the form the per-vehicle equations take: scalars, J a
    row-major 9-tuple, each gain a 3-tuple (per axis)."""

    mass: float
    gravity: float
    inertia: tuple  # J, row-major 9-tuple
    kx: tuple  # [N/m]
    kv: tuple  # [N s/m]
    k_attitude: tuple  # kR, on eR
    k_rate: tuple  # kΩ, on eΩ
    # the weight of Lee 2010's -J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) in M: 1 as Lee wrote it, 0 as
    # the Crazyflie firmware flies it (controller_lee.c has no such term)
    rotation_feedforward: float = 1.0
    # the weight of the errors' terms in Ḟ and F̈, whence Ωd and Ω̇d: 1 as Lee 2010
    # (F differentiated along the model), 0 as the Crazyflie firmware (Ωd from the
    # reference's jerk alone, controller_lee.c's hw = m/f (j - (z_d · j) z_d))
    rate_feedback: float = 1.0


class GeometricOutputs(NamedTuple):
    """What ``geometric_law`` gives, written into row i: the command and the diagnostics."""

    thrust: NDArray  # (N,) f
    moment: NDArray  # (N, 3) M
    desired_force: NDArray  # (N, 3) F
    desired_rotation: NDArray  # (N, 3, 3) Rd
    desired_rate: NDArray  # (N, 3) Ωd
    desired_acceleration: NDArray  # (N, 3) Ω̇d
    attitude_error: NDArray  # (N, 3) eR
    rate_error: NDArray  # (N, 3) eΩ


@njit(cache=True, inline="always")
def as_vector(array):
    """A 3-array as a 3-tuple."""
    return (array[0], array[1], array[2])


@njit(cache=True)
def attitude_errors(rotation, angular_velocity, desired_rotation, desired_rate):
    """``eR = ½ vee(RdᵀR - RᵀRd)``, ``eΩ = Ω - RᵀRd Ωd`` (Lee 2010), and ``RᵀRd``."""
    rd_t_r = mat_mul_tuple(transpose_tuple(desired_rotation), rotation)
    attitude_error = (0.5 * (rd_t_r[7] - rd_t_r[5]), 0.5 * (rd_t_r[2] - rd_t_r[6]),
                      0.5 * (rd_t_r[3] - rd_t_r[1]))
    r_t_rd = transpose_tuple(rd_t_r)
    rate_error = combine(1.0, angular_velocity, -1.0, mat_vec_tuple(r_t_rd, desired_rate))
    return attitude_error, rate_error, r_t_rd


@njit(cache=True, inline="always")
def force_derivative(feedback, kx, kv, error, error_rate, mass, reference_rate):
    """A derivative of F = -kx ex - kv ev + m ẍd + ...: ``feedback`` (-kx e - kv ė) + m (the
    reference's next derivative), per axis; ``feedback`` is ``GeometricLaw.rate_feedback``."""
    return (feedback * (-kx[0] * error[0] - kv[0] * error_rate[0]) + mass * reference_rate[0],
            feedback * (-kx[1] * error[1] - kv[1] * error_rate[1]) + mass * reference_rate[1],
            feedback * (-kx[2] * error[2] - kv[2] * error_rate[2]) + mass * reference_rate[2])


@njit(cache=True)
def geometric_law(x, v, R, w, reference, law, force_estimate, torque_estimate,
                  acceleration_correction):
    """Lee 2010 with NDOB compensation for one vehicle; ``reference`` a ``ReferenceVectors``
    of 3-tuples (xd, ẋd, ẍd, x⃛d, x⃜d, b1d, ḃ1d, b̈1d), ``law`` a ``GeometricLaw``,
    ``acceleration_correction`` Δa an outer loop's (a residual policy's) addition to ẍd in
    F, held constant in Ḟ and F̈ as d̂x is (so a constant Δa moves the equilibrium by
    kx ex = m Δa and asks for no rotation). Returns thrust, moment, F, Rd, Ωd, Ω̇d, eR, eΩ."""
    mass, gravity, kx, kv = law.mass, law.gravity, law.kx, law.kv
    position, velocity = reference.position, reference.velocity
    acceleration, jerk, snap = reference.acceleration, reference.jerk, reference.snap
    position_error = combine(1.0, x, -1.0, position)
    velocity_error = combine(1.0, v, -1.0, velocity)
    # F = -kx ex - kv ev + m g e3 + m (ẍd + Δa) - d̂x
    force = (-kx[0] * position_error[0] - kv[0] * velocity_error[0]
             + mass * (acceleration[0] + acceleration_correction[0]) - force_estimate[0],
             -kx[1] * position_error[1] - kv[1] * velocity_error[1]
             + mass * (acceleration[1] + acceleration_correction[1]) - force_estimate[1],
             -kx[2] * position_error[2] - kv[2] * velocity_error[2] + mass * gravity
             + mass * (acceleration[2] + acceleration_correction[2]) - force_estimate[2])
    body_z = (R[2], R[5], R[8])
    thrust = dot(force, body_z)
    body_z_dot = mat_vec_tuple(R, (w[1], -w[0], 0.0))  # d/dt R e3 = R hat(Ω) e3
    # model-predicted acceleration and jerk errors: v̇ = -g e3 + (f R e3 + d̂x) / m
    predicted = combine(thrust / mass, body_z, 1.0 / mass, force_estimate)
    acceleration_error = (predicted[0] - acceleration[0], predicted[1] - acceleration[1],
                          predicted[2] - gravity - acceleration[2])
    feedback = law.rate_feedback
    force_dot = force_derivative(feedback, kx, kv, velocity_error, acceleration_error, mass,
                                 jerk)
    thrust_dot = dot(force_dot, body_z) + dot(force, body_z_dot)
    jerk_error = combine(thrust_dot / mass, body_z, thrust / mass, body_z_dot)
    jerk_error = combine(1.0, jerk_error, -1.0, jerk)
    force_ddot = force_derivative(feedback, kx, kv, acceleration_error, jerk_error, mass,
                                  snap)
    rd, rate_d, acceleration_d = desired_attitude(force, force_dot, force_ddot,
                                                  reference.heading, reference.heading_rate,
                                                  reference.heading_acceleration)
    moment, attitude_error, rate_error = attitude_law(R, w, rd, rate_d, acceleration_d,
                                                      law.inertia, law.k_attitude, law.k_rate,
                                                      torque_estimate,
                                                      law.rotation_feedforward)
    return thrust, moment, force, rd, rate_d, acceleration_d, attitude_error, rate_error


@njit(cache=True, inline="always")
def attitude_law(R, w, rd, rate_d, acceleration_d, inertia, kR, kOmega, torque_estimate,
                 feedforward_weight):
    """Lee 2010's attitude law towards (Rd, Ωd, Ω̇d) with the torque estimate d̂Ω, its
    -J(...) term times ``feedforward_weight`` (``GeometricLaw.rotation_feedforward``);
    returns the moment, eR and eΩ. The geometric controller's monolithic law and its inner loop
    (``quad_dob_baselines.inner``) both call it."""
    attitude_error, rate_error, r_t_rd = attitude_errors(R, w, rd, rate_d)
    rate_body = mat_vec_tuple(r_t_rd, rate_d)
    acceleration_body = mat_vec_tuple(r_t_rd, acceleration_d)
    gyroscopic = cross_tuple(w, mat_vec_tuple(inertia, w))
    feedforward = mat_vec_tuple(inertia, combine(feedforward_weight, cross_tuple(w, rate_body),
                                                 -feedforward_weight, acceleration_body))
    # M = -kR eR - kΩ eΩ + Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) - d̂Ω
    moment = (-kR[0] * attitude_error[0] - kOmega[0] * rate_error[0] + gyroscopic[0]
              - feedforward[0] - torque_estimate[0],
              -kR[1] * attitude_error[1] - kOmega[1] * rate_error[1] + gyroscopic[1]
              - feedforward[1] - torque_estimate[1],
              -kR[2] * attitude_error[2] - kOmega[2] * rate_error[2] + gyroscopic[2]
              - feedforward[2] - torque_estimate[2])
    return moment, attitude_error, rate_error


# --- batch loops (one call per control step for the whole batch) ---------------------------

@njit(cache=True, inline="always")
def geometric_law_of(mass, gravity, inertia, gains):
    """A ``GeometricLaw`` from J (3, 3) and the gains (4, 3): kx, kv, kR, kΩ by row."""
    return GeometricLaw(mass, gravity, matrix_entries(inertia), as_vector(gains[0]),
                        as_vector(gains[1]), as_vector(gains[2]), as_vector(gains[3]), 1.0,
                        1.0)


@njit(cache=True, nogil=True)
def geometric_batch(start, stop, position, velocity, rotation, angular_velocity, reference,
                    law, force_estimate, torque_estimate, acceleration_correction, outputs):
    """``geometric_law`` for vehicles ``start..stop-1``: ``reference`` a ``ReferenceVectors``
    of (N, 3) arrays, ``law`` a ``GeometricLaw``, ``outputs`` a ``GeometricOutputs``, each
    passed as a plain tuple."""
    reference, law = ReferenceVectors(*reference), GeometricLaw(*law)
    outputs = GeometricOutputs(*outputs)
    # the arrays taken out once and read and written in straight lines: an array handed to
    # an inlined function with a branch or a loop counts a reference at every call
    xd, vd, ad = reference.position, reference.velocity, reference.acceleration
    jd, sd, bd = reference.jerk, reference.snap, reference.heading
    bd_rate, bd_acceleration = reference.heading_rate, reference.heading_acceleration
    for i in range(start, stop):
        f, m, force, rd, rate_d, acceleration_d, e_r, e_w = geometric_law(
            vector_at(position, i), vector_at(velocity, i), matrix_at(rotation, i),
            vector_at(angular_velocity, i),
            ReferenceVectors(vector_at(xd, i), vector_at(vd, i), vector_at(ad, i),
                             vector_at(jd, i), vector_at(sd, i), vector_at(bd, i),
                             vector_at(bd_rate, i), vector_at(bd_acceleration, i)),
            law, vector_at(force_estimate, i), vector_at(torque_estimate, i),
            vector_at(acceleration_correction, i))
        store_geometric(i, f, m, force, rd, rate_d, acceleration_d, e_r, e_w, outputs)


@njit(cache=True, inline="always")
def store_geometric(i, f, m, force, rd, rate_d, acceleration_d, e_r, e_w, outputs):
    """``geometric_law``'s results written into row i of ``outputs`` (a
    ``GeometricOutputs``), straight-line."""
    outputs.thrust[i] = f
    store_vector(outputs.moment, i, m)
    store_vector(outputs.desired_force, i, force)
    store_matrix(outputs.desired_rotation, i, rd)
    store_vector(outputs.desired_rate, i, rate_d)
    store_vector(outputs.desired_acceleration, i, acceleration_d)
    store_vector(outputs.attitude_error, i, e_r)
    store_vector(outputs.rate_error, i, e_w)


@njit(cache=True, inline="always")
def reference_at(table, r):
    """Row ``r`` of a reference table (rows, 8, 3) as ``ReferenceVectors`` of 3-tuples."""
    return ReferenceVectors(
        (table[r, 0, 0], table[r, 0, 1], table[r, 0, 2]),
        (table[r, 1, 0], table[r, 1, 1], table[r, 1, 2]),
        (table[r, 2, 0], table[r, 2, 1], table[r, 2, 2]),
        (table[r, 3, 0], table[r, 3, 1], table[r, 3, 2]),
        (table[r, 4, 0], table[r, 4, 1], table[r, 4, 2]),
        (table[r, 5, 0], table[r, 5, 1], table[r, 5, 2]),
        (table[r, 6, 0], table[r, 6, 1], table[r, 6, 2]),
        (table[r, 7, 0], table[r, 7, 1], table[r, 7, 2]))


@njit(cache=True)
def attitude_errors_batch(rotation, angular_velocity, desired_rotation, desired_rate,
                          attitude_error, rate_error, r_t_rd):
    for i in range(rotation.shape[0]):
        e_r, e_w, rt = attitude_errors(matrix_at(rotation, i), vector_at(angular_velocity, i),
                                       matrix_at(desired_rotation, i), vector_at(desired_rate, i))
        store_vector(attitude_error, i, e_r)
        store_vector(rate_error, i, e_w)
        for k in range(9):
            r_t_rd[i, k // 3, k % 3] = rt[k]


@njit(cache=True, inline="always")
def observer_estimate_vehicle(i, velocity, angular_velocity, gain, km, z_force, z_torque, fresh,
                              force_estimate, torque_estimate):
    """``d̂x = zx + Ks' v``, ``d̂Ω = zΩ + Km' Ω`` for vehicle i (``km`` a 9-tuple); a fresh
    episode starts at z = -K' x, so its first estimate is zero."""
    z_f, z_t, d_x, d_w = observer_estimate(vector_at(velocity, i),
                                           vector_at(angular_velocity, i), gain, km, fresh[i],
                                           vector_at(z_force, i), vector_at(z_torque, i))
    store_vector(z_force, i, z_f)
    store_vector(z_torque, i, z_t)
    fresh[i] = False
    store_vector(force_estimate, i, d_x)
    store_vector(torque_estimate, i, d_w)


@njit(cache=True, inline="always")
def observer_estimate(v, w, gain, km, fresh, z_force, z_torque):
    """``d̂x = zx + Ks' v``, ``d̂Ω = zΩ + Km' Ω`` from a vehicle's v, Ω and z (``km`` a
    9-tuple); a ``fresh`` episode starts at z = -K' x, so its first estimate is zero.
    Returns (zx, zΩ, d̂x, d̂Ω). Numbers in, numbers out: the callers read and write the
    arrays in straight lines (an inlined function with array parameters and a branch counts
    each array at every call)."""
    km_w = mat_vec_tuple(km, w)
    z_f = (-gain * v[0], -gain * v[1], -gain * v[2]) if fresh else z_force
    z_t = (-km_w[0], -km_w[1], -km_w[2]) if fresh else z_torque
    return z_f, z_t, combine(1.0, z_f, gain, v), add(z_t, km_w)


@njit(cache=True)
def observer_estimate_batch(velocity, angular_velocity, gain, rotational_gain, z_force,
                            z_torque, fresh, force_estimate, torque_estimate):
    km = matrix_entries(rotational_gain)
    for i in range(velocity.shape[0]):
        observer_estimate_vehicle(i, velocity, angular_velocity, gain, km, z_force, z_torque,
                                  fresh, force_estimate, torque_estimate)


@njit(cache=True, inline="always")
def observer_advance_vehicle(i, start_velocity, start_body_z, start_angular_velocity, thrust,
                             moment, end_rotation, end_angular_velocity, mass, gravity, J,
                             gain, alpha, km, a_rot, z_force, z_torque, advance_torque):
    """``observer_advance`` for vehicle i, read from and written to the batch's arrays in
    straight lines."""
    z_f, z_t = observer_advance(
        vector_at(start_velocity, i), vector_at(start_body_z, i),
        vector_at(start_angular_velocity, i), thrust[i], vector_at(moment, i),
        (end_rotation[i, 0, 2], end_rotation[i, 1, 2], end_rotation[i, 2, 2]),
        vector_at(end_angular_velocity, i), mass, gravity, J, gain, alpha, km, a_rot,
        vector_at(z_force, i), vector_at(z_torque, i), advance_torque)
    store_vector(z_force, i, z_f)
    store_vector(z_torque, i, z_t)


@njit(cache=True, inline="always")
def observer_advance(v, body_z, w0, thrust, moment, end_body_z, w1, mass, gravity, J, gain,
                     alpha, km, a_rot, z_force, z_torque, advance_torque):
    """One forward-Euler step of a vehicle's z over a control step, with the thrust
    direction and the gyroscopic torque averaged over the step's two ends (unbiased to
    second order in dt); ``J``, ``km`` and ``a_rot`` are 9-tuples. Without
    ``advance_torque`` zΩ is left to an inner loop, which advances it at its own rate.
    Returns (zx, zΩ); numbers in, numbers out."""
    lift = combine(0.5 * thrust, body_z, 0.5 * thrust, end_body_z)
    z = z_force
    # żx = -(Ks/m)(zx + Ks v - m g e3 + f R e3)
    z_f = (z[0] - alpha * (z[0] + gain * v[0] + lift[0]),
           z[1] - alpha * (z[1] + gain * v[1] + lift[1]),
           z[2] - alpha * (z[2] + gain * v[2] - mass * gravity + lift[2]))
    if not advance_torque:
        return z_f, z_torque
    return z_f, torque_observer_step(z_torque, w0, w1, moment, J, km, a_rot)


@njit(cache=True, inline="always")
def torque_observer_step(zt, w0, w1, moment, J, km, a_rot):
    """zΩ after one forward-Euler step from rates ``w0`` to ``w1`` with ``moment`` applied
    (the gyroscopic torque averaged over the two ends); ``km``, ``a_rot`` the discrete gains
    of the step's length. The control-rate observer and the inner loop's both call it."""
    gyroscopic = combine(0.5, cross_tuple(w0, mat_vec_tuple(J, w0)),
                         0.5, cross_tuple(w1, mat_vec_tuple(J, w1)))
    # żΩ = -Km J⁻¹(zΩ + Km Ω - Ω × JΩ + M)
    residual = add(combine(1.0, zt, 1.0, mat_vec_tuple(km, w0)),
                   combine(-1.0, gyroscopic, 1.0, moment))
    return combine(1.0, zt, -1.0, mat_vec_tuple(a_rot, residual))


@njit(cache=True)
def observer_advance_batch(start_velocity, start_body_z, start_angular_velocity, thrust,
                           moment, end_rotation, end_angular_velocity, mass, gravity, inertia,
                           gain, alpha, rotational_gain, alpha_rotation, z_force, z_torque,
                           advance_torque):
    J, km = matrix_entries(inertia), matrix_entries(rotational_gain)
    a_rot = matrix_entries(alpha_rotation)
    for i in range(start_velocity.shape[0]):
        observer_advance_vehicle(i, start_velocity, start_body_z, start_angular_velocity,
                                 thrust, moment, end_rotation, end_angular_velocity, mass,
                                 gravity, J, gain, alpha, km, a_rot, z_force, z_torque,
                                 advance_torque)
