"""The environments' compiled per-vehicle step: command, actuation, integration, sensing.

``QuadrotorBatch`` calls these once per step for the whole batch; they are written once
and compiled serial (small batches) and threaded (large ones).
"""

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.dynamics import (
    actuator_wrench,
    all_finite,
    body_drag,
    load_vehicle,
    sample,
    store_applied,
    store_vehicle,
    thrust_multiplier_scalar,
    vehicle_physics,
)
from quad_dob_env.dynamics.rotors import nominal_wrench, rotor_wrench, speeds_of_output
from quad_dob_env.envs.termination import ATTITUDE_LOST, CRASHED, NON_FINITE_STATE, OUT_OF_BOUNDS
from quad_dob_env.envs.ticks import (
    filtered_rate,
    fly_tick,
    held_rate,
    inner_estimate,
    keep_pose,
    rate_law,
    thrust_path_at,
    tick_factors,
)
from quad_dob_env.so3 import mat_vec_tuple

# Observations are clamped to float32's range, so a huge but finite state never becomes inf.
OBSERVATION_BOUND = float(np.finfo(np.float32).max)


@njit(cache=True, inline="always")
def _command(actions, i, rotor_mode, centre, scale_up, scale_down, allocation):
    """Normalised action -> commanded thrust and moment; 0 maps to hover."""
    s = [0.0, 0.0, 0.0, 0.0]
    for k in range(4):
        a = min(max(actions[i, k], -1.0), 1.0)  # out-of-range actions are clipped
        s[k] = centre[k] + a * (scale_up[k] if a >= 0.0 else scale_down[k])
    if rotor_mode:
        f = s[0] + s[1] + s[2] + s[3]
        m = [0.0, 0.0, 0.0]
        for row in range(3):
            for k in range(4):
                m[row] += allocation[row + 1, k] * s[k]
        return f, (m[0], m[1], m[2])
    return s[0], (s[1], s[2], s[3])


@njit(cache=True)
def command_from_action_batch(actions, rotor_mode, centre, scale_up, scale_down, allocation,
                              thrust, moment):
    """``_command`` for every row: what normalised actions command, before the actuators."""
    for i in range(actions.shape[0]):
        thrust[i], commanded = _command(actions, i, rotor_mode, centre, scale_up, scale_down,
                                        allocation)
        for k in range(3):
            moment[i, k] = commanded[k]


@njit(cache=True, inline="always")
def action_from_command_vehicle(i, thrust, moment, rotor_mode, centre, scale_up, scale_down,
                                mixer, out):
    """The inverse of ``_command`` for one vehicle: ``out[i]`` = the normalised action that
    commands ``thrust`` and ``moment`` (3-tuple), clipped to [-1, 1] (beyond the limits it
    saturates)."""
    wrench = (thrust, moment[0], moment[1], moment[2])
    for k in range(4):
        if rotor_mode:
            value = (mixer[k, 0] * wrench[0] + mixer[k, 1] * wrench[1]
                     + mixer[k, 2] * wrench[2] + mixer[k, 3] * wrench[3])
        else:
            value = wrench[k]
        offset = value - centre[k]
        action = offset / (scale_up[k] if offset >= 0.0 else scale_down[k])
        out[i, k] = min(max(action, -1.0), 1.0)


@njit(cache=True)
def action_from_command_batch(thrust, moment, inverse, out):
    """``action_from_command_vehicle`` for every row of ``thrust`` (N,), ``moment`` (N, 3);
    ``inverse`` is ``ActionMap.inverse``."""
    rotor_mode, centre, scale_up, scale_down, mixer = inverse
    for i in range(thrust.shape[0]):
        action_from_command_vehicle(i, thrust[i], (moment[i, 0], moment[i, 1], moment[i, 2]),
                                    rotor_mode, centre, scale_up, scale_down, mixer, out)


@njit(cache=True, inline="always")
def _bounded(value):
    return min(max(value, -OBSERVATION_BOUND), OBSERVATION_BOUND)


@njit(cache=True, inline="always")
def observe_vehicle(i, x, v, R, w, reference, row, rotation_mode, obs):
    """Write vehicle i's observation of state (x, v, R row-major, w) against reference row
    ``row``; return the squared position error."""
    error_sq = 0.0
    for k in range(3):
        e_x = x[k] - reference[row, 0, k]
        error_sq += e_x * e_x
        obs[i, k] = _bounded(e_x)
        obs[i, 3 + k] = _bounded(v[k] - reference[row, 1, k])
    if rotation_mode == 0:  # R row-major
        for k in range(9):
            obs[i, 6 + k] = R[k]
        j = 15
    else:  # R's first two columns, one after the other
        for c in range(2):
            for r in range(3):
                obs[i, 6 + 3 * c + r] = R[3 * r + c]
        j = 12
    for k in range(3):
        obs[i, j + k] = _bounded(w[k])
        obs[i, j + 3 + k] = reference[row, 2, k]  # desired acceleration
        obs[i, j + 6 + k] = reference[row, 5, k]  # desired heading b1d
    return error_sq


@njit(cache=True)
def _sense(i, x, v, R, w, reference, row, rotation_mode, limits, obs):
    """Write vehicle i's observation; return its termination code and position error."""
    max_error, cos_max_tilt, max_rate, has_floor, floor = limits
    error = np.sqrt(observe_vehicle(i, x, v, R, w, reference, row, rotation_mode, obs))
    code = 0  # TerminationCode.FLYING
    if error > max_error:
        code = OUT_OF_BOUNDS
    if R[8] < cos_max_tilt or max(abs(w[0]), abs(w[1]), abs(w[2])) > max_rate:
        code = ATTITUDE_LOST
    if has_floor and x[2] < floor:
        code = CRASHED
    return code, error


@njit(cache=True)
def observation_kernel(indices, position, velocity, rotation, angular_velocity, reference,
                       reference_row, rotation_mode, obs):
    """The observations of vehicles ``indices`` from a measured state (the policy's view
    when sensing is not the identity), at each vehicle's reference row."""
    for i in indices:
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        observe_vehicle(i, x, v, R, w, reference, reference_row[i], rotation_mode, obs)


class StepArguments(NamedTuple):
    """What ``step_kernel`` takes besides the slice and the actions: the core builds it by
    keyword (``QuadrotorBatch.step_arguments``), the kernel's parameters have its names."""

    action_map: tuple  # ``ActionMap.forward``
    actuation: tuple  # ``Actuator.kernel_arguments()``
    actuator: tuple  # to_wrench, to_rotors, time constant, actuator state (N, 4)
    rotors: tuple  # ``RotorModel.kernel_arguments()``
    rotor_state: tuple  # per vehicle: thrust scale (N,), battery sag rate (N,) [1/s]
    inner: tuple  # ``InnerLoop``: ticks per step, rate law, its gains, the estimate
    position: NDArray  # the state, updated in place
    velocity: NDArray
    rotation: NDArray
    angular_velocity: NDArray
    step_count: NDArray  # (N,) each vehicle's step: its time's row in the tables
    reference_row: NDArray  # (N,) its row in the reference table (its member's block)
    tables: tuple  # force, torque and wind tables shared by all vehicles
    own: tuple  # and each vehicle's own part of them
    reference: NDArray  # the reference table (members x rows, 8, 3)
    physics: tuple  # mass, g, inertia, inverse inertia, drag (per vehicle)
    dt: float
    substeps: int  # CF4 steps per inner tick (per control step without an inner loop)
    law: tuple  # the ground-effect ``ThrustLaw``
    limits: tuple  # the episode limits
    reward_weights: tuple  # position scale, effort weight
    rotation_mode: int
    obs: NDArray  # what the step writes
    reward: NDArray
    code: NDArray
    applied_thrust: NDArray
    applied_moment: NDArray
    rotor_thrusts: NDArray
    saturated: NDArray
    disturbance_force: NDArray
    disturbance_torque: NDArray
    wind_velocity: NDArray  # the air's velocity at the vehicle (world frame), written


class StartArguments(NamedTuple):
    """The core's arrays ``start_kernel`` writes a new episode into (``QuadrotorBatch.reset``
    builds it by keyword; the kernel's parameters have its names)."""

    start: tuple  # the scenario's initial position, velocity and body rates
    nominal: tuple  # the vehicle's mass, inertia, inverse inertia and drag, (1, ...) each
    position: NDArray
    velocity: NDArray
    rotation: NDArray
    angular_velocity: NDArray
    physics: tuple  # each vehicle's mass, inertia, inverse inertia and drag
    applied: tuple  # applied thrust, moment, rotor thrusts, saturated
    disturbance_force: NDArray
    disturbance_torque: NDArray
    rewards: NDArray
    step_count: NDArray
    reference_row: NDArray  # each vehicle's row of the reference table (its member's block)
    actuator_state: NDArray
    hover: NDArray  # the actuator output that holds the weight
    reference: NDArray
    rotation_mode: int
    limits: tuple
    obs: NDArray
    code: NDArray


@njit(cache=True)
def finish_vehicle_step(i, x, v, R, w, diverged, end, total, ticks, any_saturated, actions,
                        actuator, rotors, rotor_state, position, velocity, rotation,
                        angular_velocity, step_count, reference_row, tables, own, reference,
                        vehicle, law, limits, reward_weights, rotation_mode, obs, reward, code,
                        applied_thrust, applied_moment, rotor_thrusts, saturated,
                        disturbance_force, disturbance_torque, wind_velocity):
    """After vehicle i's step of ``ticks`` ticks: what was applied (the ticks' mean output),
    the end output, the last finite state, clock, observation, termination, reward, and the
    true disturbance (external, extra lift, drag, the rotors' wrench beyond the nominal)."""
    to_wrench, to_rotors, _, actuator_state = actuator
    mean = (total[0] / ticks, total[1] / ticks, total[2] / ticks, total[3] / ticks)
    saturated[i] = any_saturated
    store_applied(i, mean, to_wrench, to_rotors, applied_thrust, applied_moment, rotor_thrusts)
    for k in range(4):
        actuator_state[i, k] = end[k]
    force_table, torque_table, wind_table = tables
    force_own, torque_own, wind_own = own
    position_scale, effort_weight = reward_weights
    last = force_table.shape[1] - 1
    row = step_count[i]
    # the last finite state (where a step diverged: its start, or its last finite tick)
    store_vehicle(i, position, velocity, rotation, angular_velocity, x, v, R, w)
    step_count[i] = row + 1
    reference_row[i] += 1  # time indexes the disturbance tables, this the reference's
    code[i], error = _sense(i, x, v, R, w, reference, reference_row[i], rotation_mode, limits,
                            obs)
    if diverged:
        code[i] = NON_FINITE_STATE
    effort = 0.0
    for k in range(4):
        effort += min(actions[i, k] * actions[i, k], 1.0)
    reward[i] = np.exp(-error / position_scale) - effort_weight * effort / 4.0
    wind = sample(wind_table, row, wind_own, i, last)
    drag_body = body_drag(v, R, wind, vehicle[4], vehicle[5])
    multiplier = thrust_multiplier_scalar(x[2], law)
    if rotors[0]:
        speeds = speeds_of_output(end, rotors)
        true_force, true_moment = rotor_wrench(speeds, v, R, w, wind, rotor_state[0][i], rotors)
        nominal_thrust, nominal_moment, _ = nominal_wrench(speeds, rotors, to_wrench)
        extra = (drag_body[0] + true_force[0], drag_body[1] + true_force[1],
                 drag_body[2] + true_force[2] * multiplier - nominal_thrust)
        moment_error = (true_moment[0] - nominal_moment[0], true_moment[1] - nominal_moment[1],
                        true_moment[2] - nominal_moment[2])
    else:
        thrust_now = actuator_wrench(end, end, 0.0, to_wrench)[0]
        extra = (drag_body[0], drag_body[1], drag_body[2] + (multiplier - 1.0) * thrust_now)
        moment_error = (0.0, 0.0, 0.0)
    drag_world = mat_vec_tuple(R, extra)
    external = sample(force_table, row, force_own, i, last)
    torque = sample(torque_table, row, torque_own, i, last)
    for k in range(3):
        disturbance_force[i, k] = external[k] + drag_world[k]
        disturbance_torque[i, k] = torque[k] + moment_error[k]
        wind_velocity[i, k] = wind[k]


@njit(cache=True, nogil=True)
def step_kernel(start, stop, actions, action_map, actuation, actuator, rotors, rotor_state,
                inner, position, velocity, rotation, angular_velocity, step_count,
                reference_row, tables, own, reference, physics, dt, substeps, law, limits,
                reward_weights, rotation_mode, obs, reward, code, applied_thrust,
                applied_moment, rotor_thrusts, saturated, disturbance_force,
                disturbance_torque, wind_velocity):
    """One control step of vehicles ``start..stop-1``: action -> command -> (inner loop
    ticks: mixer -> motors -> integration) -> observation, reward, termination and the true
    disturbance (``quad_dob_env.threads`` splits the batch across cores). Called as
    ``step_kernel(start, stop, actions, *StepArguments(...))``: the record is built by
    keyword and its fields are these parameters, in this order (a test holds them equal),
    so nothing is placed by position. A record passed whole would cost numba's slow typing
    path, ~3 µs a call (20 % of a single env's step).

    With an inner loop (``inner[0]`` ticks per step) the ``thrust_rates`` rate law runs at
    every tick on the inner estimate; other actions are held over the step."""
    rotor_mode, centre, scale_up, scale_down, allocation = action_map
    _, _, time_constant, actuator_state = actuator
    mass, gravity, inertia, inertia_inverse, drag = physics
    ticks, rates = inner[0], inner[1]
    tick_dt = dt / ticks
    mean_factor, end_factor = tick_factors(time_constant, tick_dt)
    for i in range(start, stop):
        f_cmd, m_cmd = _command(actions, i, rotor_mode, centre, scale_up, scale_down, allocation)
        begin = (actuator_state[i, 0], actuator_state[i, 1], actuator_state[i, 2],
                 actuator_state[i, 3])
        row = step_count[i]
        vehicle = vehicle_physics(i, mass, gravity, inertia, inertia_inverse, drag)
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        battery = thrust_path_at(i, row, dt, rotors, rotor_state, vehicle)
        r0, w0 = R, w
        total = (0.0, 0.0, 0.0, 0.0)
        any_saturated, diverged, end = False, False, begin
        for tick in range(ticks):
            f_t, m_t = f_cmd, m_cmd
            if rates:
                seen_rotation, seen_rate = inner_estimate(i, R, w, inner, r0, w0)
                seen_rate = held_rate(i, seen_rate, inner)
                f_t, m_t = rate_law(actions, i, f_cmd, seen_rotation, seen_rate, vehicle[2],
                                    inner)
            xn, vn, Rn, wn, next_end, mean, hit, _ = fly_tick(
                i, x, v, R, w, end, f_t, m_t, actuation, actuator, rotors, rotor_state,
                battery, tables, own, row, vehicle, tick_dt, substeps, law,
                2 * substeps * tick, mean_factor, end_factor)
            end = next_end
            total = (total[0] + mean[0], total[1] + mean[1], total[2] + mean[2],
                     total[3] + mean[3])
            any_saturated = any_saturated or hit
            if not all_finite(xn, vn, Rn, wn):
                diverged = True
                break
            x, v, R, w = xn, vn, Rn, wn
            keep_pose(i, tick + 1, x, v, R, inner)
            if rates and inner[8][0]:  # the gyro low-pass samples the tick's end
                filtered_rate(i, inner_estimate(i, R, w, inner, r0, w0)[1], inner)
        finish_vehicle_step(i, x, v, R, w, diverged, end, total, ticks, any_saturated, actions,
                            actuator, rotors, rotor_state, position, velocity, rotation,
                            angular_velocity, step_count, reference_row, tables, own,
                            reference, vehicle, law, limits, reward_weights, rotation_mode,
                            obs, reward, code, applied_thrust, applied_moment, rotor_thrusts,
                            saturated, disturbance_force, disturbance_torque, wind_velocity)


@njit(cache=True)
def start_kernel(indices, offsets, rotations, scales, start, nominal, position, velocity,
                 rotation, angular_velocity, physics, applied, disturbance_force,
                 disturbance_torque, rewards, step_count, reference_row, actuator_state, hover,
                 reference, rotation_mode, limits, obs, code):
    """New episodes for vehicles ``indices`` (``QuadrotorBatch.reset``): the j-th starts at
    the scenario's state plus ``offsets[j]`` (position, then velocity) and ``rotations[j]``,
    at its ``reference_row`` (set by the caller), with
    the nominal physics times ``scales[j]`` (mass, inertia, drag), nothing applied yet, the
    rotors at hover; then its first observation and termination code. Called with
    ``*StartArguments(...)`` after ``scales``, as ``step_kernel`` is."""
    initial_position, initial_velocity, initial_angular_velocity = start
    mass0, inertia0, inertia_inverse0, drag0 = nominal
    mass, inertia, inertia_inverse, drag = physics
    applied_thrust, applied_moment, rotor_thrusts, saturated = applied
    for j in range(len(indices)):
        i = indices[j]
        for k in range(3):
            position[i, k] = initial_position[k] + offsets[j, k]
            velocity[i, k] = initial_velocity[k] + offsets[j, 3 + k]
            angular_velocity[i, k] = initial_angular_velocity[k]
            for c in range(3):
                rotation[i, k, c] = rotations[j, k, c]
                inertia[i, k, c] = inertia0[0, k, c] * scales[j, 1]
                inertia_inverse[i, k, c] = inertia_inverse0[0, k, c] / scales[j, 1]
            applied_moment[i, k] = 0.0
            disturbance_force[i, k] = 0.0
            disturbance_torque[i, k] = 0.0
        mass[i] = mass0[0] * scales[j, 0]
        applied_thrust[i] = 0.0
        saturated[i] = False
        rewards[i] = 0.0
        step_count[i] = 0
        for k in range(drag.shape[1]):  # linear, then quadratic coefficients
            drag[i, k] = drag0[0, k] * scales[j, 2]
        for k in range(4):
            rotor_thrusts[i, k] = 0.0
            actuator_state[i, k] = hover[k]
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        code[i], _ = _sense(i, x, v, R, w, reference, reference_row[i], rotation_mode, limits,
                            obs)


@njit(cache=True)
def episode_ends_kernel(termination_code, step_count, max_steps, restarted, source_rewards,
                        rewards, terminated, truncated, ended):
    """A step's rewards and episode flags; vehicles that ``restarted`` this step report
    reward 0 and no end (next-step autoreset). Returns how many episodes ended."""
    count = 0
    for i in range(termination_code.shape[0]):
        if restarted[i]:
            rewards[i] = 0.0
            terminated[i] = truncated[i] = False
        else:
            rewards[i] = source_rewards[i]
            terminated[i] = termination_code[i] > 0
            truncated[i] = not terminated[i] and step_count[i] >= max_steps
        ended[i] = terminated[i] or truncated[i]
        count += ended[i]
    return count


@njit(cache=True)
def finite_values(values):
    """Whether every entry of the 1-D ``values`` is finite (no temporary array, unlike
    ``np.isfinite(values).all()``)."""
    for value in values:
        if not np.isfinite(value):
            return False
    return True
