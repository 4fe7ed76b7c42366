"""The environments' compiled per-vehicle step: command, actuation, integration, sensing.

``QuadrotorBatch`` calls these once per step for the whole batch; they are written once
and compiled serial (small batches) and threaded (large ones). ``StepArguments`` is the
step's record of records; ``fly_vehicles`` is the one loop over an inner loop's ticks,
specialised per law (the env's own here, a controller's in
``quad_dob_composition.attitude_loop``).
"""

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.dynamics import (
    ActuatorArrays,
    BodyArrays,
    Forcing,
    StateArrays,
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
from quad_dob_env.dynamics.actuation import mixing_of
from quad_dob_env.dynamics.integrator import store_samples
from quad_dob_env.dynamics.rotors import (
    RotorDraws,
    RotorModel,
    nominal_wrench,
    rotor_wrench,
    speeds_of_output,
    true_thrust_scales,
    vehicle_draws,
)
from quad_dob_env.envs.termination import ATTITUDE_LOST, CRASHED, NON_FINITE_STATE, OUT_OF_BOUNDS
from quad_dob_env.envs.ticks import (
    EstimateError,
    InnerLoop,
    estimate_error,
    estimated,
    filtered_rate,
    fly_tick,
    gyro_state_at,
    rate_law,
    rate_law_of,
    settled_wrench,
    store_gyro,
    store_vehicle_pose,
    thrust_path_at,
    tick_factors,
)
from quad_dob_env.sensing.stage import measure_kernel
from quad_dob_env.so3 import mat_vec_tuple

# Observations are clamped to float32's range, so a huge but finite state never becomes inf.
OBSERVATION_BOUND = float(np.finfo(np.float32).max)


@njit(cache=True, inline="always")
def _command(action, action_map):
    """Normalised action (a 4-tuple) -> commanded thrust and moment (``action_map``: an
    ``ActionMapArrays`` of ``ActionMap.forward``); 0 maps to hover."""
    rotor_mode, centre = action_map.rotor_mode, action_map.centre
    scale_up, scale_down, allocation = (action_map.scale_up, action_map.scale_down,
                                        action_map.matrix)
    s = (_scaled(action[0], centre[0], scale_up[0], scale_down[0]),
         _scaled(action[1], centre[1], scale_up[1], scale_down[1]),
         _scaled(action[2], centre[2], scale_up[2], scale_down[2]),
         _scaled(action[3], centre[3], scale_up[3], scale_down[3]))
    if rotor_mode:
        f = s[0] + s[1] + s[2] + s[3]
        m = (_row_sum(allocation, 1, s), _row_sum(allocation, 2, s), _row_sum(allocation, 3, s))
        return f, m
    return s[0], (s[1], s[2], s[3])


@njit(cache=True, inline="always")
def _scaled(action, centre, scale_up, scale_down):
    """One action entry clipped to [-1, 1] and scaled about its centre."""
    a = min(max(action, -1.0), 1.0)  # out-of-range actions are clipped
    return centre + a * (scale_up if a >= 0.0 else scale_down)


@njit(cache=True, inline="always")
def _row_sum(matrix, row, s):
    """Row ``row`` of ``matrix`` times the 4-vector ``s``, summed from 0.0 in order."""
    total = 0.0
    for k in range(4):
        total += matrix[row][k] * s[k]
    return total


@njit(cache=True)
def command_from_action_batch(actions, forward, thrust, moment):
    """``_command`` for every row: what normalised actions command, before the actuators
    (``forward``: ``ActionMap.forward`` as a plain tuple)."""
    action_map = ActionMapArrays(*forward)
    for i in range(actions.shape[0]):
        thrust[i], commanded = _command((actions[i, 0], actions[i, 1], actions[i, 2],
                                         actions[i, 3]), action_map)
        for k in range(3):
            moment[i, k] = commanded[k]


@njit(cache=True, inline="always")
def action_of_command(thrust, moment, rotor_mode, centre, scale_up, scale_down, mixer):
    """The inverse of ``_command``: the normalised action (4-tuple) that commands ``thrust``
    and ``moment`` (3-tuple), clipped to [-1, 1] (beyond the limits it saturates); the
    action map's inverse comes unpacked, its constants as tuples."""
    wrench = (thrust, moment[0], moment[1], moment[2])
    return (_action_entry(0, wrench, rotor_mode, centre, scale_up, scale_down, mixer),
            _action_entry(1, wrench, rotor_mode, centre, scale_up, scale_down, mixer),
            _action_entry(2, wrench, rotor_mode, centre, scale_up, scale_down, mixer),
            _action_entry(3, wrench, rotor_mode, centre, scale_up, scale_down, mixer))


@njit(cache=True, inline="always")
def _action_entry(k, wrench, rotor_mode, centre, scale_up, scale_down, mixer):
    """Entry k of ``action_of_command``."""
    if rotor_mode:
        row = mixer[k]
        value = (row[0] * wrench[0] + row[1] * wrench[1] + row[2] * wrench[2]
                 + row[3] * wrench[3])
    else:
        value = wrench[k]
    offset = value - centre[k]
    action = offset / (scale_up[k] if offset >= 0.0 else scale_down[k])
    return min(max(action, -1.0), 1.0)


@njit(cache=True, inline="always")
def action_from_command_vehicle(i, thrust, moment, rotor_mode, centre, scale_up, scale_down,
                                mixer, out):
    """``out[i]`` = ``action_of_command``'s action (straight-line stores: an inlined
    function with an array parameter and a loop counts the array at every call)."""
    action = action_of_command(thrust, moment, rotor_mode, centre, scale_up, scale_down,
                               mixer)
    out[i, 0], out[i, 1], out[i, 2], out[i, 3] = action[0], action[1], action[2], action[3]


@njit(cache=True)
def action_from_command_batch(thrust, moment, inverse, out):
    """``action_from_command_vehicle`` for every row of ``thrust`` (N,), ``moment`` (N, 3);
    ``inverse`` is ``ActionMap.inverse`` as a plain tuple."""
    action_map = ActionMapArrays(*inverse)
    for i in range(thrust.shape[0]):
        action_from_command_vehicle(i, thrust[i], (moment[i, 0], moment[i, 1], moment[i, 2]),
                                    action_map.rotor_mode, action_map.centre,
                                    action_map.scale_up, action_map.scale_down,
                                    action_map.matrix, out)


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
def _sense(i, x, v, R, w, episode, obs):
    """Write vehicle i's observation at its reference row (``episode``: an ``Episode``);
    return its termination code and position error."""
    max_error, cos_max_tilt, max_rate, has_floor, floor = episode.limits
    error = np.sqrt(observe_vehicle(i, x, v, R, w, episode.reference,
                                    episode.reference_row[i], episode.rotation_mode, obs))
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


@njit(cache=True, nogil=True)
def measured_finish_kernel(start, stop, indices, step_count, reset, measure, observe):
    """After the physics of vehicles ``indices[start:stop]``, with sensing other than the
    identity: the sensing stage's pass (``sensing.measure_kernel``, ``measure`` its
    ``MeasureArguments``) and the observations of what it measured (``observe``:
    ``observation_kernel``'s arguments after its vehicles)."""
    measure_kernel(start, stop, indices, step_count, reset, *measure)
    observation_kernel(indices[start:stop], *observe)


class ActionMapArrays(NamedTuple):
    """``ActionMap.forward`` (and ``.inverse``, with the mixer as ``matrix``) by field."""

    rotor_mode: bool  # actions are rotor thrusts, not thrust and moments
    centre: tuple  # 4: what an action of 0 commands
    scale_up: tuple  # 4: per unit of positive action
    scale_down: tuple  # 4: per unit of negative action
    matrix: tuple  # 4 rows of 4: the allocation (forward) or the mixer (inverse)


class Episode(NamedTuple):
    """Each vehicle's clock and reference, and the settings of a step that are neither the
    vehicle nor its loop: the integration grid, the ground effect, the limits and the
    reward's weights."""

    step_count: NDArray  # (N,) each vehicle's step: its time's row in the forcing tables
    reference_row: NDArray  # (N,) its row in the reference table (its member's block)
    reference: NDArray  # the reference table (members x rows, 8, 3)
    dt: float  # [s] the control step
    substeps: int  # CF4 steps per inner tick (per control step without an inner loop)
    thrust_law: tuple  # the ground-effect ``ThrustLaw``'s values
    limits: tuple  # ``KernelLimits``' values
    position_scale: float  # the reward's ``RewardWeights``
    effort_weight: float
    rotation_mode: int  # 0: R row-major in the observation; 1: its first two columns


class StepOutputs(NamedTuple):
    """What a step writes for each vehicle besides its state."""

    obs: NDArray  # (N, size) float32, the true state's observation
    reward: NDArray  # (N,)
    code: NDArray  # (N,) int8 ``TerminationCode``
    applied_thrust: NDArray  # (N,) [N] what the nominal model says was applied
    applied_moment: NDArray  # (N, 3) [N m]
    rotor_thrusts: NDArray  # (N, 4) [N]
    saturated: NDArray  # (N,) bool, any limit hit
    # what the autopilot commanded over the step (the ticks' mean of its mixer's output
    # after saturation, in its own thrust model's newtons: before the motors' lag and the
    # true throttle map), what a real stack's estimators have (LoopOptions.estimator_wrench)
    commanded_thrust: NDArray  # (N,) [N]
    commanded_moment: NDArray  # (N, 3) [N m]
    commanded_rotor_thrusts: NDArray  # (N, 4) [N]
    disturbance_force: NDArray  # (N, 3) [N] the true disturbance, world frame
    disturbance_torque: NDArray  # (N, 3) [N m] body frame
    wind_velocity: NDArray  # (N, 3) [m/s] the air's velocity at the vehicle, world frame


class StepArguments(NamedTuple):
    """What ``step_kernel`` takes after the slice and the actions, one record per concern
    (``QuadrotorBatch.step_arguments`` builds it by keyword; the kernel's parameters have
    its names, a test holds them equal). Across the call into compiled code each record
    travels as a plain tuple (``kernel_tuples``): numba types a plain tuple in half the time
    of a named one, ~1 µs a record; the kernels name them again (``named_step``)."""

    action_map: ActionMapArrays  # ``ActionMap.forward``
    state: StateArrays  # the state, updated in place
    body: BodyArrays  # each vehicle's rigid body
    actuator: ActuatorArrays  # the mixer, the lag and each vehicle's actuator output
    rotors: RotorModel  # the rotors' own model
    draws: RotorDraws  # each vehicle's draws of its thrust path
    inner: InnerLoop  # the inner loop: ticks, rate law, estimate, gyro filter, pose fix
    forcing: Forcing  # force, torque and wind tables, shared and per vehicle
    episode: Episode  # clock, reference, grid, limits, reward weights
    outputs: StepOutputs  # what the step writes


def kernel_tuples(record: NamedTuple) -> tuple:
    """A record of records as plain tuples, as the compiled entry kernels take it."""
    return tuple(tuple(part) for part in record)


@njit(cache=True, inline="always")
def named_step(action_map, state, body, actuator, rotors, draws, inner, forcing, episode,
               outputs):
    """The ``StepArguments`` record of its fields passed as plain tuples."""
    return StepArguments(ActionMapArrays(*action_map), StateArrays(*state), BodyArrays(*body),
                         ActuatorArrays(*actuator), RotorModel(*rotors), RotorDraws(*draws),
                         InnerLoop(*inner), Forcing(*forcing), Episode(*episode),
                         StepOutputs(*outputs))


class EpisodeStart(NamedTuple):
    """Where ``start_kernel`` starts a vehicle: the scenario's initial state and the
    actuator output that holds the weight."""

    position: NDArray  # (3,)
    velocity: NDArray  # (3,)
    angular_velocity: NDArray  # (3,)
    hover: NDArray  # (4,) the actuator output at hover


class StartArguments(NamedTuple):
    """What ``start_kernel`` takes after the draws (``QuadrotorBatch.reset`` builds it by
    keyword; the kernel's parameters have its names)."""

    start: EpisodeStart
    nominal: BodyArrays  # the vehicle's nominal body, N = 1
    state: StateArrays
    body: BodyArrays
    actuator: ActuatorArrays
    episode: Episode
    outputs: StepOutputs


@njit(cache=True)
def finish_vehicles(start, stop, actions, loop):
    """After the ticks of vehicles ``start..stop-1`` (``fly_vehicles`` stored each one's
    last finite state, end output, applied wrench, and ``NON_FINITE_STATE`` as the code of
    those that diverged): clock, observation, termination, reward, and the true
    disturbance (external, extra lift, drag, the rotors' wrench beyond the nominal). One
    call a slice, every array taken out once: a call per vehicle counted a reference to
    each of the ~45 arrays of the step's records in and out, half of v1's step."""
    state, body, actuator, rotors = loop.state, loop.body, loop.actuator, loop.rotors
    draws, forcing, episode, outputs = loop.draws, loop.forcing, loop.episode, loop.outputs
    to_wrench, output = actuator.to_wrench, actuator.output
    position, velocity = state.position, state.velocity
    rotation, angular_velocity = state.rotation, state.angular_velocity
    drag = body.drag
    force, torque_table, wind_table = forcing.force, forcing.torque, forcing.wind
    force_own, torque_own, wind_own = forcing.force_own, forcing.torque_own, forcing.wind_own
    step_count, reference_row = episode.step_count, episode.reference_row
    code, reward, obs = outputs.code, outputs.reward, outputs.obs
    disturbance_force, disturbance_torque = outputs.disturbance_force, outputs.disturbance_torque
    wind_velocity = outputs.wind_velocity
    position_scale, effort_weight = episode.position_scale, episode.effort_weight
    last = force.shape[1] - 1
    for i in range(start, stop):
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        end = (output[i, 0], output[i, 1], output[i, 2], output[i, 3])
        diverged = code[i] == NON_FINITE_STATE
        row = step_count[i]
        step_count[i] = row + 1
        reference_row[i] += 1  # time indexes the forcing tables, this the reference's
        code[i], error = _sense(i, x, v, R, w, episode, obs)
        if diverged:
            code[i] = NON_FINITE_STATE
        effort = 0.0
        for k in range(4):
            effort += min(actions[i, k] * actions[i, k], 1.0)
        reward[i] = np.exp(-error / position_scale) - effort_weight * effort / 4.0
        wind = sample(wind_table, row, wind_own, i, last)
        drag_body = body_drag(v, R, wind, (drag[i, 0], drag[i, 1], drag[i, 2]),
                              (drag[i, 3], drag[i, 4], drag[i, 5]))
        multiplier = thrust_multiplier_scalar(x[2], episode.thrust_law)
        if rotors.active:
            speeds = speeds_of_output(end, rotors)
            true_force, true_moment = rotor_wrench(speeds, v, R, w, wind,
                                                   true_thrust_scales(i, draws), rotors)
            nominal_thrust, nominal_moment, _ = nominal_wrench(speeds, rotors, to_wrench)
            extra = (drag_body[0] + true_force[0], drag_body[1] + true_force[1],
                     drag_body[2] + true_force[2] * multiplier - nominal_thrust)
            moment_error = (true_moment[0] - nominal_moment[0],
                            true_moment[1] - nominal_moment[1],
                            true_moment[2] - nominal_moment[2])
        else:
            thrust_now = actuator_wrench(end, end, 0.0, to_wrench)[0]
            extra = (drag_body[0], drag_body[1], drag_body[2] + (multiplier - 1.0) * thrust_now)
            moment_error = (0.0, 0.0, 0.0)
        drag_world = mat_vec_tuple(R, extra)
        external = sample(force, row, force_own, i, last)
        torque = sample(torque_table, row, torque_own, i, last)
        for k in range(3):
            disturbance_force[i, k] = external[k] + drag_world[k]
            disturbance_torque[i, k] = torque[k] + moment_error[k]
            wind_velocity[i, k] = wind[k]


@njit(cache=True, inline="always")
def fly_vehicles(start, stop, actions, loop, law, law_constants, law_start, law_command,
                 law_after_tick, law_end, reads_estimate):
    """One control step of vehicles ``start..stop-1``: the one loop over an inner loop's
    ticks (``loop.inner.ticks``; 1 without one), for every law.

    A law is its record ``law`` and five compiled functions, fixed where the caller is
    compiled, so numba specialises this loop per law (the env's held actions and rate law,
    ``step_kernel``; a controller's attitude law, ``quad_dob_composition.attitude_loop``):

    - ``law_constants(law, inner)``: its constants as numbers, once a call;
    - ``law_start(i, law)``: vehicle i's part of it, as numbers, once a step;
    - ``law_command(action, rotation, rate, body, tick_dt, constants, vehicle, mixing)``
      each tick, from the inner-rate estimate: thrust, moment, a 4-tuple it keeps for its
      update, and the vehicle's part after it;
    - ``law_after_tick(rate_before, rate_after, request, mean_output, constants, vehicle,
      mixing)`` after each tick when ``reads_estimate`` (the gyro low-pass samples the
      tick's end): the vehicle's part after it;
    - ``law_end(i, law, vehicle)``: its state written back, once a step.

    Then ``fly_tick`` flies mixer -> battery -> motors -> physics, and ``finish_vehicles``
    scores the slice.

    Every array is taken out of the records once a call and read or written here, in
    straight lines; what the per-vehicle functions take are numbers and tuples. An array
    handed to an inlined function with a branch or a loop is counted in and out at every
    call (an atomic add on a cache line both cores share), and that counting was half of
    v1's step (docs/speed.md)."""
    state, body_arrays, actuator = loop.state, loop.body, loop.actuator
    rotors, draws, inner, forcing = loop.rotors, loop.draws, loop.inner, loop.forcing
    episode, outputs = loop.episode, loop.outputs
    ticks, dt, substeps = inner.ticks, episode.dt, episode.substeps
    thrust_law = episode.thrust_law
    tick_dt = dt / ticks
    mixing = mixing_of(actuator)
    constants = law_constants(law, inner)
    position, velocity = state.position, state.velocity
    rotation, angular_velocity = state.rotation, state.angular_velocity
    output, step_count, code = actuator.output, episode.step_count, outputs.code
    to_wrench, to_rotors = actuator.to_wrench, actuator.to_rotors
    applied_thrust, applied_moment = outputs.applied_thrust, outputs.applied_moment
    rotor_thrusts, saturated = outputs.rotor_thrusts, outputs.saturated
    commanded_thrust, commanded_moment = outputs.commanded_thrust, outputs.commanded_moment
    commanded_rotors = outputs.commanded_rotor_thrusts
    reads_command = inner.reads_command
    pose_tick, pose_position = inner.pose_tick, inner.pose_position
    pose_velocity, pose_rotation = inner.pose_velocity, inner.pose_rotation
    has_estimate, gyro_filter = inner.has_estimate, inner.gyro_filter
    estimate_rotation, estimate_rate = inner.estimate_rotation, inner.estimate_rate
    gyro_coefficients = inner.gyro_coefficients
    gyro_state, gyro_output = inner.gyro_state, inner.gyro_output
    force, torque, wind = forcing.force, forcing.torque, forcing.wind
    force_own, torque_own, wind_own = forcing.force_own, forcing.torque_own, forcing.wind_own
    samples = np.empty((2 * substeps + 1, 9))  # a tick's forcing (advance_vehicle)
    for i in range(start, stop):
        draw = vehicle_draws(i, draws)
        mean_factor, end_factor = tick_factors(draw.time_constant, tick_dt)
        row = step_count[i]
        body = vehicle_physics(i, body_arrays)
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        action = (actions[i, 0], actions[i, 1], actions[i, 2], actions[i, 3])
        battery = thrust_path_at(row, dt, rotors, draw, body)
        # the estimate's error and the gyro low-pass, read only where the law reads them
        estimating = reads_estimate and has_estimate
        error = (estimate_error(i, estimate_rotation, estimate_rate, R, w) if estimating
                 else EstimateError(R, w, w))
        filtering = reads_estimate and gyro_filter
        filter_state = (gyro_state_at(i, gyro_state) if filtering
                        else (0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
        filter_output = ((gyro_output[i, 0], gyro_output[i, 1], gyro_output[i, 2])
                         if filtering else w)
        vehicle = law_start(i, law)
        end = (output[i, 0], output[i, 1], output[i, 2], output[i, 3])
        total = (0.0, 0.0, 0.0, 0.0)
        commanded = (0.0, 0.0, 0.0, 0.0)  # the ticks' sum of the mixer's output
        any_saturated, diverged = False, False
        pose_at = pose_tick[i]
        seen_rotation, seen_rate = R, w
        if reads_estimate:
            seen_rotation, seen_rate = estimated(R, w, has_estimate, error)
            if gyro_filter:  # what the gyro low-pass last gave
                seen_rate = filter_output
        for tick in range(ticks):
            thrust, moment, request, vehicle = law_command(action, seen_rotation, seen_rate,
                                                           body, tick_dt, constants, vehicle,
                                                           mixing)
            first = 2 * substeps * tick
            for g in range(2 * substeps + 1):
                store_samples(samples, g, sample(force, row, force_own, i, first + g),
                              sample(torque, row, torque_own, i, first + g),
                              sample(wind, row, wind_own, i, first + g))
            xn, vn, Rn, wn, next_end, mean, hit, mixed = fly_tick(
                (x, v, R, w), end, thrust, moment, battery, body, tick_dt, mean_factor,
                end_factor, mixing, rotors, draw, samples, substeps, thrust_law)
            end = next_end
            total = (total[0] + mean[0], total[1] + mean[1], total[2] + mean[2],
                     total[3] + mean[3])
            commanded = (commanded[0] + mixed[0], commanded[1] + mixed[1],
                         commanded[2] + mixed[2], commanded[3] + mixed[3])
            any_saturated = any_saturated or hit
            if not all_finite(xn, vn, Rn, wn):
                diverged = True
                break
            x, v, R, w = xn, vn, Rn, wn
            if tick + 1 == pose_at:  # where the pose fix is taken within the step
                store_vehicle_pose(i, x, v, R, pose_position, pose_velocity, pose_rotation)
            if reads_estimate:  # the gyro low-pass samples the tick's end
                rotation_after, rate_after = estimated(R, w, has_estimate, error)
                if gyro_filter:
                    rate_after, filter_state = filtered_rate(rate_after, gyro_coefficients,
                                                             filter_state)
                    filter_output = rate_after
                # what the law's observer is told the motors gave: their output, or what
                # the autopilot commanded (a real stack's, LoopOptions.estimator_wrench)
                vehicle = law_after_tick(seen_rate, rate_after, request,
                                         mixed if reads_command else mean, constants,
                                         vehicle, mixing)
                seen_rotation, seen_rate = rotation_after, rate_after
        law_end(i, law, vehicle)
        if filtering:
            store_gyro(i, filter_state, filter_output, gyro_state, gyro_output)
        # what was applied (the ticks' mean output), the end output and the last finite
        # state (where a step diverged: its start, or its last finite tick)
        saturated[i] = any_saturated
        store_applied(i, (total[0] / ticks, total[1] / ticks, total[2] / ticks,
                          total[3] / ticks), to_wrench, to_rotors, applied_thrust,
                      applied_moment, rotor_thrusts)
        store_applied(i, (commanded[0] / ticks, commanded[1] / ticks, commanded[2] / ticks,
                          commanded[3] / ticks), to_wrench, to_rotors, commanded_thrust,
                      commanded_moment, commanded_rotors)
        output[i, 0], output[i, 1], output[i, 2], output[i, 3] = end[0], end[1], end[2], end[3]
        store_vehicle(i, position, velocity, rotation, angular_velocity, x, v, R, w)
        code[i] = NON_FINITE_STATE if diverged else 0  # finish_vehicles reads it
    finish_vehicles(start, stop, actions, loop)


class EnvLaw(NamedTuple):
    """The env's own law (``step_kernel``): the actions' command held over the step, or
    ``thrust_rates``' rate law at every tick."""

    action_map: ActionMapArrays  # ``ActionMap.forward``, tuples
    told_inertia: NDArray  # (N,) the rate loop's inertia over the truth


@njit(cache=True, inline="always")
def env_law_constants(law, inner):
    """The env law's constants: the action map and the rate law (``RateLaw``)."""
    return law.action_map, rate_law_of(inner)


@njit(cache=True, inline="always")
def env_law_start(i, law):
    """Vehicle i's part of the env law: its told inertia's factor."""
    return law.told_inertia[i]


@njit(cache=True, inline="always")
def env_law_command(action, rotation, rate, body, tick_dt, constants, told, mixing):
    """The actions' command, or with ``thrust_rates``' inner loop its rate law at the
    tick on the inner estimate."""
    action_map, rates = constants
    thrust, moment = _command(action, action_map)
    if rates.active:
        thrust, moment = rate_law(action, thrust, rotation, rate, body.inertia, rates, told)
    return thrust, moment, (0.0, 0.0, 0.0, 0.0), told


@njit(cache=True, inline="always")
def env_law_after_tick(rate_before, rate_after, request, mean, constants, told, mixing):
    """The env's own law keeps no state."""
    return told


@njit(cache=True, inline="always")
def env_law_end(i, law, told):
    """Nothing to write back."""


@njit(cache=True, nogil=True)
def step_kernel(start, stop, actions, action_map, state, body, actuator, rotors, draws, inner,
                forcing, episode, outputs):
    """One control step of vehicles ``start..stop-1``: action -> command -> (inner loop
    ticks: mixer -> motors -> integration) -> observation, reward, termination and the true
    disturbance (``quad_dob_env.threads`` splits the batch across cores). Called as
    ``step_kernel(start, stop, actions, *kernel_tuples(StepArguments(...)))``.

    With an inner loop the ``thrust_rates`` rate law runs at every tick on the inner
    estimate; other actions are held over the step."""
    loop = named_step(action_map, state, body, actuator, rotors, draws, inner, forcing,
                      episode, outputs)
    fly_vehicles(start, stop, actions, loop, EnvLaw(loop.action_map, loop.inner.told_inertia),
                 env_law_constants, env_law_start, env_law_command, env_law_after_tick,
                 env_law_end, loop.inner.rate_law)


@njit(cache=True)
def settled_command_kernel(start, stop, action_map, state, body, actuator, rotors, draws,
                           inner, forcing, episode, outputs, thrust, moment):
    """The nominal wrench the motors settle at for the mixer's mean output over each
    vehicle's last step (``ticks.settled_wrench``), into ``thrust`` (N,) and ``moment``
    (N, 3). Called as ``settled_command_kernel(start, stop, *kernel_tuples(step_arguments),
    thrust, moment)``."""
    loop = named_step(action_map, state, body, actuator, rotors, draws, inner, forcing,
                      episode, outputs)
    command_rows, step_count = loop.outputs.commanded_rotor_thrusts, loop.episode.step_count
    to_wrench, dt = loop.actuator.to_wrench, loop.episode.dt
    for i in range(start, stop):
        draw = vehicle_draws(i, loop.draws)
        physics = vehicle_physics(i, loop.body)
        battery = thrust_path_at(max(step_count[i] - 1, 0), dt, loop.rotors, draw, physics)
        command = (command_rows[i, 0], command_rows[i, 1], command_rows[i, 2],
                   command_rows[i, 3])
        f, m = settled_wrench(command, battery, draw, loop.rotors, to_wrench)
        thrust[i] = f
        moment[i, 0], moment[i, 1], moment[i, 2] = m[0], m[1], m[2]


@njit(cache=True)
def start_kernel(indices, offsets, rotations, scales, start, nominal, state, body, actuator,
                 episode, outputs):
    """New episodes for vehicles ``indices`` (``QuadrotorBatch.reset``): the j-th starts at
    the scenario's state plus ``offsets[j]`` (position, then velocity) and ``rotations[j]``,
    at its ``reference_row`` (set by the caller), with the nominal body times ``scales[j]``
    (mass, inertia, drag), nothing applied yet, the rotors at hover; then its first
    observation and termination code. Called with ``*kernel_tuples(StartArguments(...))``
    after ``scales``, as ``step_kernel`` is."""
    start, nominal, state = EpisodeStart(*start), BodyArrays(*nominal), StateArrays(*state)
    body, actuator = BodyArrays(*body), ActuatorArrays(*actuator)
    episode, outputs = Episode(*episode), StepOutputs(*outputs)
    position, velocity, rotation = state.position, state.velocity, state.rotation
    angular_velocity = state.angular_velocity
    inertia, inertia_inverse, drag = body.inertia, body.inertia_inverse, body.drag
    for j in range(len(indices)):
        i = indices[j]
        for k in range(3):
            position[i, k] = start.position[k] + offsets[j, k]
            velocity[i, k] = start.velocity[k] + offsets[j, 3 + k]
            angular_velocity[i, k] = start.angular_velocity[k]
            for c in range(3):
                rotation[i, k, c] = rotations[j, k, c]
                inertia[i, k, c] = nominal.inertia[0, k, c] * scales[j, 1]
                inertia_inverse[i, k, c] = nominal.inertia_inverse[0, k, c] / scales[j, 1]
            outputs.applied_moment[i, k] = 0.0
            outputs.commanded_moment[i, k] = 0.0
            outputs.disturbance_force[i, k] = 0.0
            outputs.disturbance_torque[i, k] = 0.0
        body.mass[i] = nominal.mass[0] * scales[j, 0]
        outputs.applied_thrust[i] = 0.0
        outputs.commanded_thrust[i] = 0.0
        outputs.saturated[i] = False
        outputs.reward[i] = 0.0
        episode.step_count[i] = 0
        for k in range(drag.shape[1]):  # linear, then quadratic coefficients
            drag[i, k] = nominal.drag[0, k] * scales[j, 2]
        for k in range(4):
            outputs.rotor_thrusts[i, k] = 0.0
            outputs.commanded_rotor_thrusts[i, k] = 0.0
            actuator.output[i, k] = start.hover[k]
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        outputs.code[i], _ = _sense(i, x, v, R, w, episode, outputs.obs)


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
