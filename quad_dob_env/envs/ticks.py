"""The pieces of one control step, per vehicle, compiled: an inner loop's ticks.

With a scenario's ``inner_rate`` a control step is flown as ``ticks`` intervals; each tick
the command is formed by a law (held actions or ``thrust_rates``' rate law in
``step_kernels``, a controller's attitude law in ``quad_dob_composition.attitude_loop``)
from the inner-rate estimate, then ``fly_tick`` runs the mixer, the battery, the motors and
the physics. ``InnerLoop`` is the record of the inner loop's settings and state; the one
loop over ticks, ``step_kernels.fly_vehicles``, calls these, so each equation is written
once.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

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


class InnerLoop(NamedTuple):
    """The inner loop of a core's scenario (``envs.vehicle_loop.VehicleLoop`` builds it):
    its ticks, ``thrust_rates``' rate law, the estimate the laws read, the autopilot's gyro
    low-pass and where the pose fix is taken within a step."""

    ticks: int  # inner ticks per control step (1: none)
    rate_law: bool  # thrust_rates' rate loop flies at every tick
    rate_gain: float  # [1/s] its k_ω
    max_rate: float  # [rad/s] the rate an action of 1 commands
    moment_limit: NDArray  # (3,) [N m] its moments' limits
    has_estimate: bool  # the inner loop reads an estimate, not the truth
    estimate_rotation: NDArray  # (N, 3, 3) R̂ at the step's start
    estimate_rate: NDArray  # (N, 3) Ω̂ at the step's start
    gyro_filter: bool  # the autopilot's gyro low-pass (2nd-order Butterworth)
    gyro_coefficients: tuple  # (b0, b1, b2, a1, a2)
    gyro_state: NDArray  # (N, 3, 2) its transposed direct form II state
    gyro_output: NDArray  # (N, 3) its last output
    # (N,) int64 each vehicle's tick (from 1) after which its pose fix is taken; 0: the
    # step's end (an unmodelled pose latency may be drawn per episode)
    pose_tick: NDArray
    pose_position: NDArray  # (N, 3) where it is kept
    pose_velocity: NDArray
    pose_rotation: NDArray  # (N, 3, 3)
    told_inertia: NDArray  # (N,) the rate loop's inertia over the truth (model tolerance)


@njit(cache=True, inline="always")
def inner_estimate(i, R, w, inner, start_rotation, start_rate):
    """The attitude and rates an inner loop reads now: the truth's, moved by the estimate's
    error at the step's start (``inner``'s estimate arrays; none: the truth itself). The
    error is held over the step: the gyroscope's noise is drawn at the control rate."""
    if not inner.has_estimate:
        return R, w
    e, r0, w0 = inner.estimate_rotation, start_rotation, start_rate
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
    rates = inner.estimate_rate
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
    """The gyro low-pass (``inner.gyro_*``) stepped once with vehicle i's ``rate``; returns
    its output (the input itself when off). Tuples, not a list: a list is a heap allocation
    per call."""
    if not inner.gyro_filter:
        return rate
    coefficients, state, output = inner.gyro_coefficients, inner.gyro_state, inner.gyro_output
    return (_filtered_axis(i, 0, rate[0], coefficients, state, output),
            _filtered_axis(i, 1, rate[1], coefficients, state, output),
            _filtered_axis(i, 2, rate[2], coefficients, state, output))


@njit(cache=True, inline="always")
def held_rate(i, rate, inner):
    """What the gyro low-pass last gave vehicle i (``rate`` itself when off)."""
    if not inner.gyro_filter:
        return rate
    output = inner.gyro_output
    return (output[i, 0], output[i, 1], output[i, 2])


@njit(cache=True, inline="always")
def store_vehicle_pose(i, x, v, R, position, velocity, rotation):
    """Vehicle i's state where its pose fix is taken within the step (after tick
    ``InnerLoop.pose_tick[i]``), into the inner loop's ``pose_*`` arrays."""
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
    vehicle's ``inertia`` times ``inner.told_inertia[i]``."""
    gain, max_rate, limit = inner.rate_gain, inner.max_rate, inner.moment_limit
    told = inner.told_inertia[i]  # the controller's inertia over the truth (v3's tolerance)
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
def fly_tick(i, state, start, thrust, moment, battery, row, body, tick_dt, first_sample,
             mean_factor, end_factor, actuator, rotors, draw, forcing, episode):
    """One inner tick (a whole control step without an inner loop) of vehicle i from
    ``state`` (x, v, R, Ω) and actuator output ``start``: the command (thrust, moment)
    through the mixer's limits and the battery, the motors and the physics (the step's
    records, ``StepArguments``' fields; ``body``: the vehicle's ``RigidBody``). Returns the
    new state, the actuator output at its end, the tick's mean output as rotor thrusts or
    the wrench (what the nominal model says was applied), whether a limit was hit and what
    the mixer made of the command. The records come one by one, taken out of the step's
    record once a call: each taking of a record takes a reference to every array in it;
    ``draw`` is the vehicle's ``VehicleDraws``, numbers only."""
    time_constant = draw.time_constant
    spin_down = draw.spin_down_time_constant
    command, saturated = actuate_vehicle(thrust, moment, actuator.code, actuator.mixer,
                                         actuator.max_rotor_thrust, actuator.max_total_thrust,
                                         actuator.moment_limit)
    command_scale, per_newton, full = battery
    if rotors.active:
        if rotors.throttle:  # the throttle map (speed motors): ω_c = sqrt(T / (κ_s k_F))
            true_thrusts, ceiling = rotor_thrusts_of(command, per_newton, full,
                                                     draw.thrust_model_factor,
                                                     rotors.autopilot_thrust_model_factor)
            saturated = saturated or ceiling
            target = motor_target(true_thrusts, 1.0 / draw.thrust_scale, rotors)
        else:
            target = motor_target(command, command_scale, rotors)
        if rotors.speed_motors:  # the nominal model's k_F times the mean of ω² over the tick
            squares = mean_square_speeds(start, target, time_constant, tick_dt, spin_down)
            k = rotors.thrust_coefficient
            mean = (k * squares[0], k * squares[1], k * squares[2], k * squares[3])
        else:
            mean = lagged_output(start, target, mean_factor)
    else:
        target = command
        mean = lagged_output(start, command, mean_factor)
    if rotors.active and rotors.speed_motors and spin_down > 0.0:
        end = lagged_each(start, target, speed_lag_factors(start, target, time_constant,
                                                           spin_down, tick_dt))
    else:
        end = lagged_output(start, target, end_factor)
    xn, vn, Rn, wn = advance_vehicle(i, state, start, target, time_constant, spin_down,
                                     actuator.to_wrench, forcing, row, body, tick_dt,
                                     episode.substeps, episode.thrust_law, rotors,
                                     draw.true_thrust_scales, first_sample)
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
def thrust_path_at(row, dt, rotors, draw, body):
    """What the battery leaves a vehicle at step ``row`` (``draw``: its ``VehicleDraws``,
    ``body``: its ``RigidBody``), as
    (thrust per command, throttle per believed newton, full-throttle thrust [N]): with the
    throttle map (``dynamics.throttle``) its last two at the true hover throttle
    ``t_h0 + r t``; else thrust uncertainty's ``(1 - sag_rate t)²`` (1 without it) first."""
    if rotors.throttle:
        per_newton, full = throttle_state(
            draw.hover_throttle + draw.hover_throttle_drift * row * dt,
            draw.hover_estimate_factor, 0.25 * body.mass * body.gravity,
            rotors.believed_hover_rotor_thrust, draw.thrust_model_factor,
            rotors.autopilot_thrust_model_factor)
        return 1.0, per_newton, full
    if not rotors.active:
        return 1.0, 0.0, 0.0
    left = max(1.0 - draw.sag_rate * row * dt, 0.0)  # an empty pack makes no thrust
    return left * left, 0.0, 0.0
