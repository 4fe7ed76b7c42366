"""The pieces of one control step, per vehicle, compiled: an inner loop's ticks.

With a scenario's ``inner_rate`` a control step is flown as ``ticks`` intervals; each tick
the command is formed (held, ``thrust_rates``' rate law here, or a controller's attitude law
in ``quad_dob_composition.attitude_loop``) from the inner-rate estimate, then
``fly_tick`` runs the mixer, the battery, the motors and the physics. ``step_kernel``
and the composition's loop both call these, so each equation is written once.
"""

import math

import numpy as np
from numba import njit

from quad_dob_env.dynamics import (
    actuate_vehicle,
    advance_vehicle,
    lag_factor,
)
from quad_dob_env.dynamics.rotors import (
    lagged_each,
    lagged_output,
    mean_square_speeds,
    motor_target,
    speed_lag_factors,
)
from quad_dob_env.dynamics.throttle import rotor_thrusts_of, throttle_state
from quad_dob_env.so3 import cross_tuple, mat_mul_tuple, mat_vec_tuple


@njit(cache=True, inline="always")
def inner_estimate(i, R, w, inner, start_rotation, start_rate):
    """The attitude and rates an inner loop reads now: the truth's, moved by the estimate's
    error at the step's start (``inner``'s estimate arrays; none: the truth itself). The
    error is held over the step: the gyroscope's noise is drawn at the control rate."""
    if not inner[5]:
        return R, w
    e, r0, w0 = inner[6], start_rotation, start_rate
    # E = R̂₀ R₀ᵀ, the world-frame error of the estimate at the step's start
    error = (e[i, 0, 0] * r0[0] + e[i, 0, 1] * r0[1] + e[i, 0, 2] * r0[2],
             e[i, 0, 0] * r0[3] + e[i, 0, 1] * r0[4] + e[i, 0, 2] * r0[5],
             e[i, 0, 0] * r0[6] + e[i, 0, 1] * r0[7] + e[i, 0, 2] * r0[8],
             e[i, 1, 0] * r0[0] + e[i, 1, 1] * r0[1] + e[i, 1, 2] * r0[2],
             e[i, 1, 0] * r0[3] + e[i, 1, 1] * r0[4] + e[i, 1, 2] * r0[5],
             e[i, 1, 0] * r0[6] + e[i, 1, 1] * r0[7] + e[i, 1, 2] * r0[8],
             e[i, 2, 0] * r0[0] + e[i, 2, 1] * r0[1] + e[i, 2, 2] * r0[2],
             e[i, 2, 0] * r0[3] + e[i, 2, 1] * r0[4] + e[i, 2, 2] * r0[5],
             e[i, 2, 0] * r0[6] + e[i, 2, 1] * r0[7] + e[i, 2, 2] * r0[8])
    rates = inner[7]
    return (mat_mul_tuple(error, R),
            (w[0] + rates[i, 0] - w0[0], w[1] + rates[i, 1] - w0[1], w[2] + rates[i, 2] - w0[2]))


def butterworth_coefficients(cutoff: float, rate: float) -> tuple[float, ...]:
    """A 2nd-order Butterworth low-pass at ``cutoff`` [Hz] sampled at ``rate`` [Hz], by the
    bilinear transform prewarped at the cutoff: (b0, b1, b2, a1, a2) of
    ``y_k = b0 x_k + b1 x_{k-1} + b2 x_{k-2} - a1 y_{k-1} - a2 y_{k-2}``."""
    k = math.tan(math.pi * cutoff / rate)  # the prewarped cutoff, ω_c T / 2
    norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
    b0 = k * k * norm
    return (b0, 2.0 * b0, b0, 2.0 * (k * k - 1.0) * norm,
            (1.0 - math.sqrt(2.0) * k + k * k) * norm)


@njit(cache=True, inline="always")
def _filtered_axis(i, k, x, coefficients, state, output):
    """Axis k of the gyro low-pass stepped once with input ``x``, in transposed direct
    form II; returns its output."""
    b0, b1, b2, a1, a2 = coefficients
    y = b0 * x + state[i, k, 0]
    state[i, k, 0] = b1 * x - a1 * y + state[i, k, 1]
    state[i, k, 1] = b2 * x - a2 * y
    output[i, k] = y
    return y


@njit(cache=True, inline="always")
def filtered_rate(i, rate, inner):
    """The gyro low-pass (``inner[8]``: on, its coefficients, state (N, 3, 2) and last
    output (N, 3)) stepped once with vehicle i's ``rate``; returns its output (the input
    itself when off). Tuples, not a list: a list is a heap allocation per call."""
    on, coefficients, state, output = inner[8]
    if not on:
        return rate
    return (_filtered_axis(i, 0, rate[0], coefficients, state, output),
            _filtered_axis(i, 1, rate[1], coefficients, state, output),
            _filtered_axis(i, 2, rate[2], coefficients, state, output))


@njit(cache=True, inline="always")
def held_rate(i, rate, inner):
    """What the gyro low-pass last gave vehicle i (``rate`` itself when off)."""
    if not inner[8][0]:
        return rate
    output = inner[8][3]
    return (output[i, 0], output[i, 1], output[i, 2])


@njit(cache=True, inline="always")
def keep_pose(i, tick, x, v, R, inner):
    """Vehicle i's state after tick ``tick`` (counted from 1) where the pose fix is taken
    within the step (``inner[9]``: that tick, 0 for none, and the arrays it goes to)."""
    when, position, velocity, rotation = inner[9]
    if tick == when:
        for k in range(3):
            position[i, k] = x[k]
            velocity[i, k] = v[k]
            for c in range(3):
                rotation[i, k, c] = R[3 * k + c]


@njit(cache=True, inline="always")
def rate_law(actions, i, thrust, R, w, inertia, inner):
    """``thrust_rates``' inner loop: ``M = J k_ω (ω_cmd - ω) + ω × J ω`` (Lee et al. 2010,
    eq. 16's rate and gyroscopic terms), ``ω_cmd = a₁..₃ · max_rate``, each moment clipped
    to its limit as the action map would; J is the inertia the autopilot is told, the
    vehicle's ``inertia`` times ``inner[10][i]``."""
    gain, max_rate, limit = inner[2], inner[3], inner[4]
    told = inner[10][i]  # the controller's inertia over the truth (v3's model tolerance)
    inertia = (inertia[0] * told, inertia[1] * told, inertia[2] * told, inertia[3] * told,
               inertia[4] * told, inertia[5] * told, inertia[6] * told, inertia[7] * told,
               inertia[8] * told)
    error = (min(max(actions[i, 1], -1.0), 1.0) * max_rate - w[0],
             min(max(actions[i, 2], -1.0), 1.0) * max_rate - w[1],
             min(max(actions[i, 3], -1.0), 1.0) * max_rate - w[2])
    torque = mat_vec_tuple(inertia, (gain * error[0], gain * error[1], gain * error[2]))
    spin = cross_tuple(w, mat_vec_tuple(inertia, w))
    return thrust, (min(max(torque[0] + spin[0], -limit[0]), limit[0]),
                    min(max(torque[1] + spin[1], -limit[1]), limit[1]),
                    min(max(torque[2] + spin[2], -limit[2]), limit[2]))


@njit(cache=True, inline="always")
def fly_tick(i, x, v, R, w, start, thrust, moment, actuation, actuator, rotors, rotor_state,
             battery, tables, own, row, vehicle, tick_dt, substeps, law, first_sample,
             mean_factor, end_factor):
    """One inner tick (a whole control step without an inner loop) of vehicle i from
    actuator output ``start``: the command (thrust, moment) through the mixer's limits and
    the battery, the motors and the physics. Returns the new state, the actuator output at
    its end, the tick's mean output as rotor thrusts or the wrench (what the nominal model
    says was applied), whether a limit was hit and what the mixer made of the command."""
    to_wrench, _, time_constant, _ = actuator
    code, mixer, max_rotor, max_total, moment_limit = actuation
    command, saturated = actuate_vehicle(thrust, moment, code, mixer, max_rotor, max_total,
                                         moment_limit)
    if rotors[0]:
        if rotors[12]:  # the throttle map (speed motors): ω_c = sqrt(T / (κ_s k_F))
            true_thrusts, ceiling = rotor_thrusts_of(command, battery[1], battery[2],
                                                     rotors[13], rotors[14])
            saturated = saturated or ceiling
            target = motor_target(true_thrusts, 1.0 / rotor_state[0][i], rotors)
        else:
            target = motor_target(command, battery[0], rotors)
        if rotors[1]:  # the nominal model's k_F times the mean of ω² over the tick
            squares = mean_square_speeds(start, target, time_constant, tick_dt, rotors[11])
            k = rotors[3]
            mean = (k * squares[0], k * squares[1], k * squares[2], k * squares[3])
        else:
            mean = lagged_output(start, target, mean_factor)
    else:
        target = command
        mean = lagged_output(start, command, mean_factor)
    if rotors[0] and rotors[1] and rotors[11] > 0.0:
        end = lagged_each(start, target, speed_lag_factors(start, target, time_constant,
                                                           rotors[11], tick_dt))
    else:
        end = lagged_output(start, target, end_factor)
    xn, vn, Rn, wn = advance_vehicle(x, v, R, w, start, target, time_constant, to_wrench,
                                     tables, row, own, i, vehicle, tick_dt, substeps, law,
                                     rotors, rotor_state[0][i], first_sample)
    return xn, vn, Rn, wn, end, mean, saturated, command


@njit(cache=True, inline="always")
def tick_factors(time_constant, tick_dt):
    """The share of the old actuator output in a tick's mean, and left at its end."""
    if time_constant > 0.0:
        mean_factor = time_constant / tick_dt * (1.0 - np.exp(-tick_dt / time_constant))
    else:
        mean_factor = 0.0
    return mean_factor, lag_factor(tick_dt, time_constant)


@njit(cache=True, inline="always")
def thrust_path_at(i, row, dt, rotors, rotor_state, vehicle):
    """What the battery leaves vehicle i at step ``row`` (``vehicle``: its physics), as
    (thrust per command, throttle per believed newton, full-throttle thrust [N]): with the
    throttle map (``dynamics.throttle``) its last two at the true hover throttle
    ``t_h0 + r t``; else thrust uncertainty's ``(1 - sag_rate t)²`` (1 without it) first."""
    if rotors[12]:
        per_newton, full = throttle_state(
            rotor_state[2][i] + rotor_state[3][i] * row * dt, rotor_state[4][i],
            0.25 * vehicle[0] * vehicle[1], rotors[15], rotors[13], rotors[14])
        return 1.0, per_newton, full
    if not rotors[0]:
        return 1.0, 0.0, 0.0
    left = max(1.0 - rotor_state[1][i] * row * dt, 0.0)  # an empty pack makes no thrust
    return left * left, 0.0, 0.0
