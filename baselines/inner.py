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


class InnerConstants(NamedTuple):
    """An ``InnerLaw``'s constants as numbers (``inner_constants``), read once a call:
    numbers count no references where arrays would, per vehicle and tick."""

    code: int
    gains: tuple  # 5 rows of 3, as ``InnerLaw.gains``
    inertia: tuple  # J, row-major 9-tuple
    has_observer: bool
    observer_gain: tuple  # Km', row-major 9-tuple
    observer_alpha: tuple  # I - e^{-Km J⁻¹ T}, row-major 9-tuple


class VehicleInner(NamedTuple):
    """Vehicle i's part of an ``InnerLaw`` over one control step, as numbers
    (``vehicle_inner``): the targets held over the step and the law's own state, which
    the ticks carry as values and ``store_vehicle_inner`` writes back once."""

    desired_force: tuple  # F
    desired_rotation: tuple  # Rd, row-major
    desired_rate: tuple  # Ωd
    desired_acceleration: tuple  # Ω̇d
    torque_state: tuple  # zΩ
    integral: tuple  # PID rate integral
    previous_error: tuple  # PID rate error of the last tick
    fresh: bool  # PID: no last tick yet
    excess: tuple  # PID: requested minus mixed moment, last tick


@njit(cache=True, inline="always")
def _row(table, k):
    return (table[k, 0], table[k, 1], table[k, 2])


@njit(cache=True, inline="always")
def inner_constants(law):
    """``law``'s (an ``InnerLaw`` or a record with its fields) ``InnerConstants``."""
    gains, stack = law.gains, law.observer_gains
    return InnerConstants(law.code, (_row(gains, 0), _row(gains, 1), _row(gains, 2),
                                     _row(gains, 3), _row(gains, 4)),
                          matrix_entries(law.inertia), law.has_observer,
                          matrix_at(stack, OBSERVER_GAIN), matrix_at(stack, OBSERVER_ALPHA))


@njit(cache=True, inline="always")
def vehicle_inner(i, law):
    """Vehicle i's ``VehicleInner`` from ``law``'s arrays (straight-line reads)."""
    return VehicleInner(vector_at(law.desired_force, i), matrix_at(law.desired_rotation, i),
                        vector_at(law.desired_rate, i), vector_at(law.desired_acceleration, i),
                        vector_at(law.torque_state, i), vector_at(law.integral, i),
                        vector_at(law.previous_error, i), law.fresh[i],
                        vector_at(law.excess, i))


@njit(cache=True, inline="always")
def store_vehicle_inner(i, law, vehicle):
    """Write the law's own state of ``vehicle`` (a ``VehicleInner``) back into row i of
    ``law``'s arrays (straight-line writes; a law that kept no state writes back what it
    read)."""
    store_vector(law.torque_state, i, vehicle.torque_state)
    store_vector(law.integral, i, vehicle.integral)
    store_vector(law.previous_error, i, vehicle.previous_error)
    law.fresh[i] = vehicle.fresh
    store_vector(law.excess, i, vehicle.excess)


@njit(cache=True)
def inner_command(R, w, constants, vehicle, tick):
    """A vehicle's thrust and moment at an inner tick of ``tick`` s, from the inner-rate
    estimate (R row-major 9-tuple, Ω), the law's ``InnerConstants`` and the vehicle's
    ``VehicleInner``; returns them and the ``VehicleInner`` after the tick's command (the
    PID's integrator and last error move here). Numbers in, numbers out."""
    gains = constants.gains
    force = vehicle.desired_force
    thrust = force[0] * R[2] + force[1] * R[5] + force[2] * R[8]  # f = F · R e3
    rd, rate_d = vehicle.desired_rotation, vehicle.desired_rate
    acceleration_d = vehicle.desired_acceleration
    J = constants.inertia
    gyroscopic = cross_tuple(w, mat_vec_tuple(J, w))
    if constants.code == LEE:
        torque_estimate = (0.0, 0.0, 0.0)
        if constants.has_observer:  # d̂Ω = zΩ + Km' Ω
            km_w = mat_vec_tuple(constants.observer_gain, w)
            z = vehicle.torque_state
            torque_estimate = (z[0] + km_w[0], z[1] + km_w[1], z[2] + km_w[2])
        moment, _, _ = attitude_law(R, w, rd, rate_d, acceleration_d, J, gains[0], gains[1],
                                    torque_estimate, 1.0)
        return thrust, moment, vehicle
    attitude_error, rate_error, r_t_rd = attitude_errors(R, w, rd, rate_d)
    rate_body = mat_vec_tuple(r_t_rd, rate_d)
    acceleration_body = mat_vec_tuple(r_t_rd, acceleration_d)
    if constants.code == PID:
        kp_attitude, kp, ki, kd, limit = gains
        # ω_cmd = RᵀRd Ωd - K_att eR, e_ω = Ω - ω_cmd
        command = combine(1.0, rate_body, -kp_attitude[0], attitude_error)
        error = combine(1.0, w, -1.0, command)
        pushed = mat_vec_tuple(J, error)
        last = vehicle.previous_error if not vehicle.fresh else error
        integral, excess = vehicle.integral, vehicle.excess
        axis0 = _pid_axis(0, error, pushed, last, acceleration_body, kp, ki, kd, limit,
                          integral, excess, tick)
        axis1 = _pid_axis(1, error, pushed, last, acceleration_body, kp, ki, kd, limit,
                          integral, excess, tick)
        axis2 = _pid_axis(2, error, pushed, last, acceleration_body, kp, ki, kd, limit,
                          integral, excess, tick)
        torque = mat_vec_tuple(J, (axis0[0], axis1[0], axis2[0]))
        v = vehicle
        after = VehicleInner(v.desired_force, v.desired_rotation, v.desired_rate,
                             v.desired_acceleration, v.torque_state,
                             (axis0[1], axis1[1], axis2[1]), error, False, v.excess)
        return thrust, (gyroscopic[0] + torque[0], gyroscopic[1] + torque[1],
                        gyroscopic[2] + torque[2]), after
    # SMC: s_R = eΩ + λ_R eR, M = Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) - J(λ_R eΩ + η_R sat)
    lam, eta, boundary = gains[0][0], gains[1][0], gains[2][0]
    spin = cross_tuple(w, rate_body)
    shaped = (_smc_axis(0, spin, acceleration_body, rate_error, attitude_error, lam, eta,
                        boundary),
              _smc_axis(1, spin, acceleration_body, rate_error, attitude_error, lam, eta,
                        boundary),
              _smc_axis(2, spin, acceleration_body, rate_error, attitude_error, lam, eta,
                        boundary))
    torque = mat_vec_tuple(J, shaped)
    return thrust, (gyroscopic[0] - torque[0], gyroscopic[1] - torque[1],
                    gyroscopic[2] - torque[2]), vehicle


@njit(cache=True, inline="always")
def _pid_axis(k, error, pushed, last, acceleration_body, kp, ki, kd, limit, integral,
              excess, tick):
    """Axis k of the PID's rate law: its integrator stepped, then its angular acceleration;
    returns both."""
    stepped = integral[k]
    # an axis waits while the mixer clipped its moment and integrating pushes further
    if not excess[k] * -pushed[k] > 0.0:
        stepped = min(max(integral[k] + error[k] * tick, -limit[0]), limit[0])
    return (acceleration_body[k] - kp[0] * error[k] - ki[0] * stepped
            - kd[0] * (error[k] - last[k]) / tick), stepped


@njit(cache=True, inline="always")
def _smc_axis(k, spin, acceleration_body, rate_error, attitude_error, lam, eta, boundary):
    """Axis k of the SMC's shaped angular acceleration."""
    surface = rate_error[k] + lam * attitude_error[k]
    saturated = min(max(surface / boundary, -1.0), 1.0)
    return spin[k] - acceleration_body[k] + lam * rate_error[k] + eta * saturated


@njit(cache=True)
def inner_applied(rate_before, rate_after, requested, mixed, applied, constants, vehicle):
    """After a tick: the rotational observer advanced with the ``applied`` moment between
    the estimated rates ``rate_before`` and ``rate_after``; the PID's excess of its own
    ``requested`` moment over what the mixer makes of that request (``mixed``). Returns the
    vehicle's ``VehicleInner`` after it."""
    v = vehicle  # a NamedTuple in compiled code has no _replace: built again
    if constants.code == LEE and constants.has_observer:
        z = torque_observer_step(v.torque_state, rate_before, rate_after, applied,
                                 constants.inertia, constants.observer_gain,
                                 constants.observer_alpha)
        return VehicleInner(v.desired_force, v.desired_rotation, v.desired_rate,
                            v.desired_acceleration, z, v.integral, v.previous_error, v.fresh,
                            v.excess)
    if constants.code == PID:
        excess = (_excess(requested[0], mixed[0]), _excess(requested[1], mixed[1]),
                  _excess(requested[2], mixed[2]))
        return VehicleInner(v.desired_force, v.desired_rotation, v.desired_rate,
                            v.desired_acceleration, v.torque_state, v.integral,
                            v.previous_error, v.fresh, excess)
    return v


@njit(cache=True, inline="always")
def _excess(requested, mixed):
    """The requested minus the mixed moment on an axis, below 1e-9 none."""
    difference = requested - mixed
    return difference if abs(difference) >= 1e-9 else 0.0
