"""The residual's compiled per-vehicle pieces (``quad_dob_env.residual``): the
command, the reward and the extra observation, written once: the separate stages call them
over the batch, ``quad_dob_composition.fused``'s single pass per vehicle."""

from numba import njit

from quad_dob_env.envs.step_kernels import action_from_command_vehicle


@njit(cache=True, inline="always")
def body_frame_errors_vehicle(i, position, velocity, rotation, reference_position,
                              reference_velocity, out):
    """``out[i] = [Rᵀ(x - x_d), Rᵀ(v - v_d)]``, for the residual's observation."""
    for k in range(3):
        position_error, velocity_error = 0.0, 0.0
        for j in range(3):
            position_error += rotation[i, j, k] * (position[i, j] - reference_position[j])
            velocity_error += rotation[i, j, k] * (velocity[i, j] - reference_velocity[j])
        out[i, k] = position_error
        out[i, 3 + k] = velocity_error


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
def residual_observation_vehicle(i, base_thrust, base_moment, force_estimate, torque_estimate,
                                 estimate_scale, position, velocity, rotation, reference,
                                 row_index, rotor_mode, centre, scale_up, scale_down, mixer,
                                 base_action, body_errors, extra):
    """Vehicle i's 16 extra observation entries (table in ``quad_dob_env.residual``); the action
    map's inverse comes unpacked (``ActionMap.inverse``)."""
    action_from_command_vehicle(i, base_thrust[i], (base_moment[i, 0], base_moment[i, 1],
                                                    base_moment[i, 2]),
                                rotor_mode, centre, scale_up, scale_down, mixer, base_action)
    body_frame_errors_vehicle(i, position, velocity, rotation, reference[row_index, 0],
                              reference[row_index, 1], body_errors)
    for k in range(4):
        extra[i, k] = base_action[i, k]
    for k in range(3):
        extra[i, 4 + k] = min(max(force_estimate[i, k] * estimate_scale[k], -1e3), 1e3)
        extra[i, 7 + k] = min(max(torque_estimate[i, k] * estimate_scale[3 + k], -1e3), 1e3)
    for k in range(6):
        extra[i, 10 + k] = min(max(body_errors[i, k], -1e3), 1e3)


@njit(cache=True)
def residual_observation_kernel(base_thrust, base_moment, force_estimate, torque_estimate,
                                estimate_scale, position, velocity, rotation, reference,
                                reference_row, inverse, base_action, body_errors, extra):
    """``residual_observation_vehicle`` for every vehicle, at its own reference row
    (the separate stages' way to the same entries the fused pass writes)."""
    rotor_mode, centre, scale_up, scale_down, mixer = inverse
    for i in range(base_thrust.shape[0]):
        residual_observation_vehicle(i, base_thrust, base_moment, force_estimate,
                                     torque_estimate, estimate_scale, position, velocity,
                                     rotation, reference, reference_row[i], rotor_mode, centre,
                                     scale_up, scale_down, mixer, base_action, body_errors,
                                     extra)


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
