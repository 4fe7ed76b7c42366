"""Each vehicle's lag reaches the compiled tick as a per-vehicle array set at a reset
(``RotorDraws.time_constant``), so ``LoopOptions.motor_time_constant_scale`` may be a
(low, high) range drawn per episode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_env.loop_options import LoopOptions
from quad_dob_env.scenarios import make_scenario

RANGE = (0.6, 1.8)


def _flight(env: gym.Env, steps: int = 25) -> np.ndarray:
    actions = np.random.default_rng(5).uniform(-0.3, 0.3, (steps, 4)).astype(np.float32)
    for action in actions:
        env.step(action)
    state = env.unwrapped.core.state
    return np.concatenate([state.position[0], state.velocity[0], state.rotation[0].ravel()])


def test_a_fixed_scale_is_every_vehicles_lag():
    scenario = make_scenario("hover-calm", benchmark="v3", motor_time_constant_scale=1.5)
    env = gym.make_vec("QuadDOB/Hover-v3", num_envs=3, vectorization_mode="vector_entry_point",
                       scenario=scenario)
    env.reset(seed=0)
    draws = env.unwrapped.core.loop.draws
    up, down = scenario.rotor_time_constants
    np.testing.assert_array_equal(draws.time_constant, up)
    # the spin-down's is 0 where it is the spin-up's (one time constant both ways)
    np.testing.assert_array_equal(draws.spin_down_time_constant, 0.0 if down == up else down)
    assert "motor_time_constant_scale" not in env.unwrapped.core.sampled[0]


def test_a_range_draws_each_episode_and_flies_as_that_value_fixed():
    drawn = gym.make("QuadDOB/Hover-v3",
                     scenario_options={"motor_time_constant_scale": RANGE})
    _, info = drawn.reset(seed=11)
    scale = info["sampled"]["motor_time_constant_scale"]
    assert RANGE[0] <= scale <= RANGE[1]
    _, again = drawn.reset(seed=11)
    assert again["sampled"]["motor_time_constant_scale"] == scale  # seeded
    _, other = drawn.reset(seed=12)
    assert other["sampled"]["motor_time_constant_scale"] != scale
    # the drawn scale flies bit for bit as the same scale given fixed: the per-vehicle
    # value is what the tick reads, and the range's stream moves no other draw
    fixed = gym.make("QuadDOB/Hover-v3", scenario_options={"motor_time_constant_scale": scale})
    drawn.reset(seed=11)
    fixed.reset(seed=11)
    loop = drawn.unwrapped.core.loop
    up, down = fixed.unwrapped.scenario.rotor_time_constants
    assert loop.draws.time_constant[0] == up
    assert loop.draws.spin_down_time_constant[0] == (0.0 if down == up else down)
    np.testing.assert_array_equal(_flight(drawn), _flight(fixed))


def test_vehicles_of_one_batch_fly_their_own_lag():
    env = gym.make_vec("QuadDOB/Hover-v3", num_envs=4, vectorization_mode="vector_entry_point",
                       scenario_options={"motor_time_constant_scale": RANGE})
    env.reset(seed=3)
    scales = env.unwrapped.core.loop.time_constant_scale
    assert len(set(scales.tolist())) == 4
    up = env.unwrapped.scenario.loop.rotor_time_constants(env.unwrapped.scenario.vehicle, 1.0)[0]
    np.testing.assert_array_equal(env.unwrapped.core.loop.draws.time_constant, up * scales)


def test_a_scale_range_is_checked():
    with pytest.raises(ValueError, match="must be > 0"):
        LoopOptions(motor_time_constant_scale=(0.0, 1.0))
    with pytest.raises(ValueError, match="low <= high"):
        LoopOptions(motor_time_constant_scale=(2.0, 1.0))
    scenario = make_scenario("hover-calm", benchmark="v3",
                             motor_time_constant_scale=RANGE)
    with pytest.raises(ValueError, match="range drawn per episode"):
        _ = scenario.rotor_time_constants
