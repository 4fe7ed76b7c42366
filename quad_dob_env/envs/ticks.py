"""The pieces of one control step, per vehicle, compiled: an inner loop's ticks.

With a scenario's ``inner_rate`` a control step is flown as ``ticks`` intervals; each tick
the command is formed by a law (held actions or ``thrust_rates``' rate law in
``step_kernels``, a controller's attitude law in ``quad_dob_composition.attitude_loop``)
from the inner-rate estimate, then ``fly_tick`` runs the mixer, the battery, the motors and
the physics. ``InnerLoop`` is the record of the inner loop's settings and state; the one
loop over ticks, ``step_kernels.fly_vehicles``, calls these, so each equation is written
once.
"""

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.dynamics import (
    actuate_vehicle,
    actuator_wrench,
    advance_vehicle,
    lag_factor,
)
from quad_dob_env.dynamics.rotors import (
    lagged_each,
    lagged_output,
    mean_square_speeds,
    motor_target,
    nominal_wrench,
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
    moment_limit: tuple  # (3,) [N m] its moments' limits
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
    # the attitude laws' observers are told what the autopilot commanded at each tick, not
    # what the motors gave (LoopOptions.estimator_wrench "commanded")
    reads_command: bool


class RateLaw(NamedTuple):
    """``thrust_rates``' rate loop as numbers (``InnerLoop``'s fields, read once a call)."""

    active: bool  # it flies at every tick
    gain: float  # [1/s] k_ω
    max_rate: float  # [rad/s] the rate an action of 1 commands
    moment_limit: tuple  # (3,) [N m]


@njit(cache=True, inline="always")
def rate_law_of(inner):
    """``inner``'s ``RateLaw``."""
    return RateLaw(inner.rate_law, inner.rate_gain, inner.max_rate, inner.moment_limit)


class EstimateError(NamedTuple):
    """What moves a vehicle's inner-rate estimate off the truth over a step, as numbers
    (``estimate_error``): ``E = R̂₀ R₀ᵀ`` and the rates at the step's start, the
    estimate's and the truth's. The error is held over the step: the gyroscope's noise is
    drawn at the control rate."""

    rotation: tuple  # E, row-major
    estimated_rate: tuple  # Ω̂₀
    true_rate: tuple  # Ω₀


@njit(cache=True, inline="always")
def estimate_error(i, estimate_rotation, estimate_rate, r0, w0):
    """Vehicle i's ``EstimateError`` from the estimate at the step's start
    (``InnerLoop.estimate_rotation``, ``estimate_rate``) and the truth's ``r0``, ``w0``."""
    e = estimate_rotation
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
    return EstimateError(error, (estimate_rate[i, 0], estimate_rate[i, 1],
                                 estimate_rate[i, 2]), w0)


@njit(cache=True, inline="always")
def estimated(R, w, has_estimate, error):
    """The attitude and rates an inner loop reads now: the truth's, moved by the
    estimate's ``error`` (an ``EstimateError``) when it reads an estimate."""
    if not has_estimate:
        return R, w
    rates, w0 = error.estimated_rate, error.true_rate
    return (mat_mul_tuple(error.rotation, R),
            (w[0] + rates[0] - w0[0], w[1] + rates[1] - w0[1], w[2] + rates[2] - w0[2]))


@njit(cache=True, inline="always")
def _filtered_axis(x, coefficients, s0, s1):
    """One axis of the gyro low-pass stepped once with input ``x`` from its state (s0,
    s1), in transposed direct form II; returns its output and next state."""
    b0, b1, b2, a1, a2 = coefficients
    y = b0 * x + s0
    return y, b1 * x - a1 * y + s1, b2 * x - a2 * y


@njit(cache=True, inline="always")
def filtered_rate(rate, coefficients, state):
    """The gyro low-pass stepped once with ``rate``, from its ``state`` (a 6-tuple: each
    axis's two values); returns its output and next state. Tuples, not a list: a list is
    a heap allocation per call."""
    y0, a0, b0 = _filtered_axis(rate[0], coefficients, state[0], state[1])
    y1, a1, b1 = _filtered_axis(rate[1], coefficients, state[2], state[3])
    y2, a2, b2 = _filtered_axis(rate[2], coefficients, state[4], state[5])
    return (y0, y1, y2), (a0, b0, a1, b1, a2, b2)


@njit(cache=True, inline="always")
def gyro_state_at(i, state):
    """Vehicle i's gyro low-pass state as a 6-tuple (``InnerLoop.gyro_state``, (N, 3, 2))."""
    return (state[i, 0, 0], state[i, 0, 1], state[i, 1, 0], state[i, 1, 1], state[i, 2, 0],
            state[i, 2, 1])


@njit(cache=True, inline="always")
def store_gyro(i, filtered, output, state, output_array):
    """Write vehicle i's gyro low-pass ``state`` (6-tuple) and its last ``output``."""
    state[i, 0, 0], state[i, 0, 1], state[i, 1, 0] = filtered[0], filtered[1], filtered[2]
    state[i, 1, 1], state[i, 2, 0], state[i, 2, 1] = filtered[3], filtered[4], filtered[5]
    output_array[i, 0], output_array[i, 1], output_array[i, 2] = output[0], output[1], output[2]


@njit(cache=True, inline="always")
def store_vehicle_pose(i, x, v, R, position, velocity, rotation):
    """Vehicle i's state where its pose fix is taken within the step (after tick
    ``InnerLoop.pose_tick[i]``), into the inner loop's ``pose_*`` arrays."""
    position[i, 0], position[i, 1], position[i, 2] = x[0], x[1], x[2]
    velocity[i, 0], velocity[i, 1], velocity[i, 2] = v[0], v[1], v[2]
    rotation[i, 0, 0], rotation[i, 0, 1], rotation[i, 0, 2] = R[0], R[1], R[2]
    rotation[i, 1, 0], rotation[i, 1, 1], rotation[i, 1, 2] = R[3], R[4], R[5]
    rotation[i, 2, 0], rotation[i, 2, 1], rotation[i, 2, 2] = R[6], R[7], R[8]


@njit(cache=True, inline="always")
def rate_law(action, thrust, R, w, inertia, rates, told):
    """``thrust_rates``' inner loop: ``M = J k_ω (ω_cmd - ω) + ω × J ω`` (Lee et al. 2010,
    eq. 16's rate and gyroscopic terms), ``ω_cmd = a₁..₃ · max_rate`` (``action`` a
    4-tuple), each moment clipped to its limit as the action map would (``rates`` a
    ``RateLaw``); J is the inertia the autopilot is told, the vehicle's ``inertia`` times
    ``told`` (its ``InnerLoop.told_inertia``)."""
    gain, max_rate, limit = rates.gain, rates.max_rate, rates.moment_limit
    inertia = (inertia[0] * told, inertia[1] * told, inertia[2] * told, inertia[3] * told,
               inertia[4] * told, inertia[5] * told, inertia[6] * told, inertia[7] * told,
               inertia[8] * told)
    error = (min(max(action[1], -1.0), 1.0) * max_rate - w[0],
             min(max(action[2], -1.0), 1.0) * max_rate - w[1],
             min(max(action[3], -1.0), 1.0) * max_rate - w[2])
    torque = mat_vec_tuple(inertia, (gain * error[0], gain * error[1], gain * error[2]))
    spin = cross_tuple(w, mat_vec_tuple(inertia, w))
    return thrust, (min(max(torque[0] + spin[0], -limit[0]), limit[0]),
                    min(max(torque[1] + spin[1], -limit[1]), limit[1]),
                    min(max(torque[2] + spin[2], -limit[2]), limit[2]))


@njit(cache=True, inline="always")
def fly_tick(state, start, thrust, moment, battery, body, tick_dt, mean_factor, end_factor,
             mixing, rotors, draw, samples, substeps, thrust_law):
    """One inner tick (a whole control step without an inner loop) of a vehicle from
    ``state`` (x, v, R, Ω) and actuator output ``start``: the command (thrust, moment)
    through the mixer's limits (``mixing``, an ``actuation.Mixing``) and the battery, the
    motors and the physics (``body``: the vehicle's ``RigidBody``, ``draw`` its
    ``VehicleDraws``, ``samples`` the forcing on the tick's grid, ``forcing_samples``).
    Returns the new state, the actuator output at its end, the tick's mean output as rotor
    thrusts or the wrench (what the nominal model says was applied), whether a limit was
    hit and what the mixer made of the command. Numbers in, but for ``samples``: an array
    handed to an inlined function is counted in and out at every call."""
    time_constant = draw.time_constant
    spin_down = draw.spin_down_time_constant
    command, saturated = actuate_vehicle(thrust, moment, mixing.code, mixing.mixer,
                                         mixing.max_rotor_thrust, mixing.max_total_thrust,
                                         mixing.moment_limit)
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
    xn, vn, Rn, wn = advance_vehicle(state, start, target, time_constant, spin_down,
                                     mixing.to_wrench, samples, body, tick_dt, substeps,
                                     thrust_law, rotors, draw.true_thrust_scales)
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


@njit(cache=True, inline="always")
def settled_wrench(command, battery, draw, rotors, to_wrench):
    """The nominal model's (f, M) once the motors have settled on the mixer's ``command``
    (its four outputs) through the battery and the throttle map, as ``fly_tick`` drives
    them: what the thrust path gives for a command, without the motors' lag. Numbers in,
    numbers out (``battery``: ``thrust_path_at``'s triple, ``draw`` the vehicle's
    ``VehicleDraws``)."""
    command_scale, per_newton, full = battery
    if not rotors.active:
        return actuator_wrench(command, command, 0.0, to_wrench)
    if rotors.throttle:
        true_thrusts, _ = rotor_thrusts_of(command, per_newton, full, draw.thrust_model_factor,
                                           rotors.autopilot_thrust_model_factor)
        target = motor_target(true_thrusts, 1.0 / draw.thrust_scale, rotors)
    else:
        target = motor_target(command, command_scale, rotors)
    if rotors.speed_motors:
        thrust, moment, _ = nominal_wrench(target, rotors, to_wrench)
        return thrust, moment
    return actuator_wrench(target, target, 0.0, to_wrench)
