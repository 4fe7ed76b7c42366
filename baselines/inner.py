"""The controllers' attitude laws at an inner loop's rate (Benchmark v2), compiled per
vehicle.

An autopilot runs its position loop at 50-100 Hz and its attitude and rate loop at several
hundred (PX4: attitude at ``IMU_INTEG_RATE`` 200 Hz, rates at ``IMU_GYRO_RATEMAX`` 400 Hz).
With a scenario's ``inner_rate`` a controller's ``compute`` is its outer part: once per
control step it leaves, in its ``diagnostics``, the desired thrust vector F, attitude Rd
and the rates Ωd, Ω̇d it flies towards, and at every tick of the inner loop the law below
turns the inner-rate estimate of (R, Ω) into ``f = F · R e3`` and a moment:

- ``LEE`` (geometric, geometric + NDOB): ``attitude_law`` (kR, kΩ, feed-forward)
  with the rotational observer's ``d̂Ω = zΩ + Km' Ω``, zΩ advanced each tick with the moment
  applied (``torque_observer_step``, its gains discretised at the tick);
- ``PID``: attitude P to a rate command, rate PID with its integrator and the
  conditional-integration anti-windup of ``pid`` at the tick's period;
- ``SMC``: ``smc``'s attitude sliding law.

``InnerLaw`` is what a controller hands the loop (``Controller.inner_law``); the loop that
runs it between the physics' ticks lives in ``quad_dob_composition.attitude_loop``.
``tests/test_vehicle_loop.py`` holds each law, run once a step, to the controller's own
control-rate equations.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_baselines.geometric_kernels import (
    attitude_errors,
    attitude_law,
    matrix_at,
    store_vector,
    torque_observer_step,
    vector_at,
)
from quad_dob_env.flatness import combine
from quad_dob_env.so3 import cross_tuple, mat_vec_tuple, matrix_entries

NO_LAW, LEE, PID, SMC = 0, 1, 2, 3
# the matrices of ``InnerLaw.observer_gains``: Km', and I - e^{-Km J⁻¹ T}
OBSERVER_GAIN, OBSERVER_ALPHA = 0, 1


class InnerLaw(NamedTuple):
    """A controller's attitude law for the inner loop, with the arrays it reads and keeps
    (the controller's own, not copies)."""

    code: int  # LEE, PID or SMC
    gains: NDArray  # (5, 3): LEE kR, kΩ; PID attitude kp, rate kp, ki, kd, integral limit;
    # SMC λ_R, η_R, φ_R
    inertia: NDArray  # (3, 3) the controller's model of J
    desired_force: NDArray  # (N, 3) F, held over the control step
    desired_rotation: NDArray  # (N, 3, 3) Rd
    desired_rate: NDArray  # (N, 3) Ωd
    desired_acceleration: NDArray  # (N, 3) Ω̇d
    has_observer: bool
    observer_gains: NDArray  # (2, 3, 3) Km' and I - e^{-Km J⁻¹ T} at the tick's period T
    torque_state: NDArray  # (N, 3) zΩ
    integral: NDArray  # (N, 3) PID rate integral
    previous_error: NDArray  # (N, 3) PID rate error of the last tick
    fresh: NDArray  # (N,) PID: no last tick yet
    excess: NDArray  # (N, 3) PID: requested minus mixed moment, last tick


def inner_law(code: int, gains: NDArray, inertia: NDArray, diagnostics: dict,
              n: int, observer: tuple | None = None, pid_state: tuple | None = None
              ) -> InnerLaw:
    """An ``InnerLaw`` from a controller's ``diagnostics`` and state (``observer``:
    (Km', alpha, zΩ); ``pid_state``: (integral, previous error, fresh, excess))."""
    table = np.zeros((5, 3))
    table[:len(gains)] = gains
    empty = np.zeros((n, 3))
    km, alpha, z_torque = observer if observer is not None else (np.zeros((3, 3)),
                                                                 np.zeros((3, 3)), empty)
    integral, previous, fresh, excess = (pid_state if pid_state is not None else
                                         (empty, empty, np.zeros(n, dtype=np.bool_), empty))
    return InnerLaw(code, table, np.ascontiguousarray(inertia, dtype=float),
                    diagnostics["desired_force"], diagnostics["desired_rotation"],
                    diagnostics["desired_angular_velocity"],
                    diagnostics["desired_angular_acceleration"], observer is not None,
                    np.stack([km, alpha]), z_torque, integral, previous, fresh, excess)


def held_torque_estimate(torque_estimate: NDArray) -> tuple:
    """``inner_law``'s ``observer`` for a torque estimate made once per control step and
    held over its ticks (INDI's, L1's): the observer's form with zero gains, under which
    ``d̂Ω = zΩ`` and ``inner_applied`` leaves zΩ as it is."""
    return np.zeros((3, 3)), np.zeros((3, 3)), torque_estimate


@njit(cache=True, inline="always")
def _row(table, k):
    return (table[k, 0], table[k, 1], table[k, 2])


@njit(cache=True)
def inner_command(i, R, w, law, tick):
    """Vehicle i's thrust and moment at an inner tick of ``tick`` s, from the inner-rate
    estimate (R row-major 9-tuple, Ω) and ``law``, an ``InnerLaw`` or a record with its
    fields (a composition's law adds its own)."""
    gains = law.gains
    force = vector_at(law.desired_force, i)
    thrust = force[0] * R[2] + force[1] * R[5] + force[2] * R[8]  # f = F · R e3
    rd = matrix_at(law.desired_rotation, i)
    rate_d = vector_at(law.desired_rate, i)
    acceleration_d = vector_at(law.desired_acceleration, i)
    J = matrix_entries(law.inertia)
    gyroscopic = cross_tuple(w, mat_vec_tuple(J, w))
    if law.code == LEE:
        torque_estimate = (0.0, 0.0, 0.0)
        if law.has_observer:  # d̂Ω = zΩ + Km' Ω
            km_w = mat_vec_tuple(_matrix(law.observer_gains, OBSERVER_GAIN), w)
            z = vector_at(law.torque_state, i)
            torque_estimate = (z[0] + km_w[0], z[1] + km_w[1], z[2] + km_w[2])
        moment, _, _ = attitude_law(R, w, rd, rate_d, acceleration_d, J, _row(gains, 0),
                                    _row(gains, 1), torque_estimate)
        return thrust, moment
    attitude_error, rate_error, r_t_rd = attitude_errors(R, w, rd, rate_d)
    rate_body = mat_vec_tuple(r_t_rd, rate_d)
    acceleration_body = mat_vec_tuple(r_t_rd, acceleration_d)
    if law.code == PID:
        kp_attitude, kp, ki, kd, limit = (_row(gains, 0), _row(gains, 1), _row(gains, 2),
                                          _row(gains, 3), _row(gains, 4))
        integral, excess = law.integral, law.excess
        # ω_cmd = RᵀRd Ωd - K_att eR, e_ω = Ω - ω_cmd
        command = combine(1.0, rate_body, -kp_attitude[0], attitude_error)
        error = combine(1.0, w, -1.0, command)
        pushed = mat_vec_tuple(J, error)
        last = vector_at(law.previous_error, i) if not law.fresh[i] else error
        acceleration = (
            _pid_axis(i, 0, error, pushed, last, acceleration_body, kp, ki, kd, limit,
                      integral, excess, tick),
            _pid_axis(i, 1, error, pushed, last, acceleration_body, kp, ki, kd, limit,
                      integral, excess, tick),
            _pid_axis(i, 2, error, pushed, last, acceleration_body, kp, ki, kd, limit,
                      integral, excess, tick))
        store_vector(law.previous_error, i, error)
        law.fresh[i] = False
        torque = mat_vec_tuple(J, acceleration)
        return thrust, (gyroscopic[0] + torque[0], gyroscopic[1] + torque[1],
                        gyroscopic[2] + torque[2])
    # SMC: s_R = eΩ + λ_R eR, M = Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) - J(λ_R eΩ + η_R sat)
    lam, eta, boundary = gains[0, 0], gains[1, 0], gains[2, 0]
    spin = cross_tuple(w, rate_body)
    shaped = (_smc_axis(0, spin, acceleration_body, rate_error, attitude_error, lam, eta,
                        boundary),
              _smc_axis(1, spin, acceleration_body, rate_error, attitude_error, lam, eta,
                        boundary),
              _smc_axis(2, spin, acceleration_body, rate_error, attitude_error, lam, eta,
                        boundary))
    torque = mat_vec_tuple(J, shaped)
    return thrust, (gyroscopic[0] - torque[0], gyroscopic[1] - torque[1],
                    gyroscopic[2] - torque[2])


@njit(cache=True, inline="always")
def _pid_axis(i, k, error, pushed, last, acceleration_body, kp, ki, kd, limit, integral,
              excess, tick):
    """Axis k of the PID's rate law: its integrator stepped, then its angular acceleration.
    Per axis, not a list: a list is a heap allocation per call."""
    # an axis waits while the mixer clipped its moment and integrating pushes further
    if not excess[i, k] * -pushed[k] > 0.0:
        integral[i, k] = min(max(integral[i, k] + error[k] * tick, -limit[0]), limit[0])
    return (acceleration_body[k] - kp[0] * error[k] - ki[0] * integral[i, k]
            - kd[0] * (error[k] - last[k]) / tick)


@njit(cache=True, inline="always")
def _smc_axis(k, spin, acceleration_body, rate_error, attitude_error, lam, eta, boundary):
    """Axis k of the SMC's shaped angular acceleration."""
    surface = rate_error[k] + lam * attitude_error[k]
    saturated = min(max(surface / boundary, -1.0), 1.0)
    return spin[k] - acceleration_body[k] + lam * rate_error[k] + eta * saturated


@njit(cache=True, inline="always")
def _matrix(stack, k):
    return matrix_entries(stack[k])


@njit(cache=True)
def inner_applied(i, rate_before, rate_after, requested, mixed, applied, law):
    """After a tick: the rotational observer advanced with the ``applied`` moment between
    the estimated rates ``rate_before`` and ``rate_after``; the PID's excess of its own
    ``requested`` moment over what the mixer makes of that request (``mixed``); ``law`` as
    ``inner_command`` takes it."""
    if law.code == LEE and law.has_observer:
        store_vector(law.torque_state, i, torque_observer_step(
            vector_at(law.torque_state, i), rate_before, rate_after, applied,
            matrix_entries(law.inertia), _matrix(law.observer_gains, OBSERVER_GAIN),
            _matrix(law.observer_gains, OBSERVER_ALPHA)))
    elif law.code == PID:
        for k in range(3):
            difference = requested[k] - mixed[k]
            law.excess[i, k] = difference if abs(difference) >= 1e-9 else 0.0
