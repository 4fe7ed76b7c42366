"""The residual's compiled per-vehicle pieces (``quad_dob_env.residual``): the
command, the reward and the extra observation, written once: the separate stages call them
over the batch, ``quad_dob_composition.fused``'s single pass per vehicle."""

from numba import njit

from quad_dob_env.envs.step_kernels import action_from_command_vehicle, action_of_command
from quad_dob_env.so3 import matrix_at, vector_at


@njit(cache=True, inline="always")
def body_frame_errors(x, v, R, reference_position, reference_velocity):
    """``[Rᵀ(x - x_d), Rᵀ(v - v_d)]`` for the residual's observation (R row-major), each
    sum from 0.0 over the world axes in order."""
    return (_body_axis(0, x, R, reference_position), _body_axis(1, x, R, reference_position),
            _body_axis(2, x, R, reference_position), _body_axis(0, v, R, reference_velocity),
            _body_axis(1, v, R, reference_velocity), _body_axis(2, v, R, reference_velocity))


@njit(cache=True, inline="always")
def _body_axis(k, value, R, reference):
    """Body axis k of ``Rᵀ(value - reference)``."""
    total = 0.0
    for j in range(3):
        total += R[3 * j + k] * (value[j] - reference[j])
    return total


@njit(cache=True)
def residual_command_kernel(start, stop, residual, residual_range, base_thrust, base_moment,
                            inverse, clipped, requested_thrust, actions):
    """Base command + ``residual_range ·`` clipped residual, as the env actions that command
    it (clipped to [-1, 1] by the inverse action map, ``ActionMap.inverse``)."""
    rotor_mode, centre, scale_up, scale_down, mixer = inverse
    for i in range(start, stop):
        for k in range(4):
            clipped[i, k] = min(max(residual[i, k], -1.0), 1.0)
        requested_thrust[i] = base_thrust[i] + clipped[i, 0] * residual_range[0]
        moment = (base_moment[i, 0] + clipped[i, 1] * residual_range[1],
                  base_moment[i, 1] + clipped[i, 2] * residual_range[2],
                  base_moment[i, 2] + clipped[i, 3] * residual_range[3])
        action_from_command_vehicle(i, requested_thrust[i], moment, rotor_mode, centre,
                                    scale_up, scale_down, mixer, actions)


@njit(cache=True)
def residual_addition_kernel(start, stop, clipped, residual_range, addition):
    """What an inner loop's attitude law adds at every tick for vehicles ``start..stop-1``:
    the clipped residual times its range (thrust [N], moments [N m])."""
    for i in range(start, stop):
        for k in range(4):
            addition[i, k] = clipped[i, k] * residual_range[k]


@njit(cache=True)
def residual_reward_kernel(start, stop, clipped, core_rewards, effort_weight, rate_weight,
                           previous, rewards):
    """The env's reward minus ``effort_weight · mean(a²)`` and ``rate_weight ·
    mean((a - a_prev)²)``, a the residual flown and a_prev the step before's (zero at an
    episode's start); ``previous`` then holds a."""
    for i in range(start, stop):
        effort = 0.0
        rate = 0.0
        for k in range(4):
            effort += clipped[i, k] * clipped[i, k]
            change = clipped[i, k] - previous[i, k]
            rate += change * change
            previous[i, k] = clipped[i, k]
        rewards[i] = core_rewards[i] - effort_weight * (effort / 4.0) - rate_weight * (rate / 4.0)


@njit(cache=True, inline="always")
def residual_observation(thrust, moment, force_estimate, torque_estimate, scale, x, v, R,
                         reference_position, reference_velocity, inverse):
    """A vehicle's 16 extra observation entries (table in ``quad_dob_env.residual``) as a
    tuple, and the base's action and body-frame errors they hold: numbers in, numbers out
    (``scale`` the 6 estimate scales, ``inverse`` the action map's, tuples)."""
    rotor_mode, centre, scale_up, scale_down, mixer = inverse
    action = action_of_command(thrust, moment, rotor_mode, centre, scale_up, scale_down, mixer)
    errors = body_frame_errors(x, v, R, reference_position, reference_velocity)
    extra = (action[0], action[1], action[2], action[3],
             _bounded(force_estimate[0] * scale[0]), _bounded(force_estimate[1] * scale[1]),
             _bounded(force_estimate[2] * scale[2]), _bounded(torque_estimate[0] * scale[3]),
             _bounded(torque_estimate[1] * scale[4]), _bounded(torque_estimate[2] * scale[5]),
             _bounded(errors[0]), _bounded(errors[1]), _bounded(errors[2]),
             _bounded(errors[3]), _bounded(errors[4]), _bounded(errors[5]))
    return extra, action, errors


@njit(cache=True, inline="always")
def store_residual_observation(i, observed, base_action, body_errors, extra):
    """Row i of the extra observation, the base's action and the body-frame errors
    (``residual_observation``'s three tuples), written straight-line."""
    entries, action, errors = observed
    base_action[i, 0], base_action[i, 1] = action[0], action[1]
    base_action[i, 2], base_action[i, 3] = action[2], action[3]
    body_errors[i, 0], body_errors[i, 1], body_errors[i, 2] = errors[0], errors[1], errors[2]
    body_errors[i, 3], body_errors[i, 4], body_errors[i, 5] = errors[3], errors[4], errors[5]
    extra[i, 0], extra[i, 1], extra[i, 2], extra[i, 3] = (entries[0], entries[1], entries[2],
                                                          entries[3])
    extra[i, 4], extra[i, 5], extra[i, 6], extra[i, 7] = (entries[4], entries[5], entries[6],
                                                          entries[7])
    extra[i, 8], extra[i, 9], extra[i, 10], extra[i, 11] = (entries[8], entries[9],
                                                            entries[10], entries[11])
    extra[i, 12], extra[i, 13], extra[i, 14], extra[i, 15] = (entries[12], entries[13],
                                                              entries[14], entries[15])


@njit(cache=True, inline="always")
def _bounded(value):
    """An extra observation entry held within ±1e3."""
    return min(max(value, -1e3), 1e3)


@njit(cache=True)
def residual_observation_kernel(base_thrust, base_moment, force_estimate, torque_estimate,
                                estimate_scale, position, velocity, rotation, reference,
                                reference_row, inverse, base_action, body_errors, extra):
    """``residual_observation`` for every vehicle, at its own reference row (the separate
    stages' way to the same entries the fused pass writes)."""
    scale = (estimate_scale[0], estimate_scale[1], estimate_scale[2], estimate_scale[3],
             estimate_scale[4], estimate_scale[5])
    for i in range(base_thrust.shape[0]):
        row = reference_row[i]
        observed = residual_observation(
            base_thrust[i], vector_at(base_moment, i), vector_at(force_estimate, i),
            vector_at(torque_estimate, i), scale, vector_at(position, i),
            vector_at(velocity, i), matrix_at(rotation, i), reference_vector(reference, row, 0),
            reference_vector(reference, row, 1), inverse)
        store_residual_observation(i, observed, base_action, body_errors, extra)


@njit(cache=True, inline="always")
def reference_vector(table, row, k):
    """Vector k of a reference table's row (rows, 8, 3) as a 3-tuple."""
    return (table[row, k, 0], table[row, k, 1], table[row, k, 2])


@njit(cache=True)
def join_columns(left, right, out):
    """``out = [left | right]`` row by row: numpy's concatenate copies each short row
    separately, ~5 µs for 256 observations."""
    width = left.shape[1]
    for i in range(left.shape[0]):
        for k in range(width):
            out[i, k] = left[i, k]
        for k in range(right.shape[1]):
            out[i, width + k] = right[i, k]
