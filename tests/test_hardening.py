"""Bad input, divergence and determinism, with hypothesis fuzzing.

Profiles (conftest): ``ci`` (CI=true) 50 examples per test, ``dev`` 100. The two stepping
fuzzers fly 16 vehicles x 150 steps per example: 2 x 50 x 2,400 = 240,000 fuzzed vehicle-steps
under ``ci``, 480,000 under ``dev``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from quad_dob_composition import ResidualVectorEnv
from quad_dob_env import list_scenarios
from quad_dob_env.envs import TERMINATION_REASONS, QuadrotorEnv, QuadrotorVectorEnv
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.so3 import exp

VEHICLES, STEPS = 16, 150
REASONS = {*TERMINATION_REASONS, "time_limit"}
FUZZ = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])

finite = st.floats(-1e300, 1e300, allow_nan=False)
extreme_or_nan = st.one_of(finite, st.sampled_from([np.nan, np.inf, -np.inf, 1e308, -1.0,
                                                    1.0, 0.0]))


def _fly_and_check(env: QuadrotorVectorEnv, actions: np.ndarray) -> set[str]:
    reasons: set[str] = set()
    for step in range(STEPS):
        obs, rewards, terminated, truncated, info = env.step(actions[step % len(actions)])
        assert np.isfinite(obs).all() and np.isfinite(rewards).all()
        assert env.observation_space.contains(obs)
        ended = terminated | truncated
        assert np.array_equal(info.get("_termination_reason", np.zeros_like(ended)), ended)
        if ended.any():
            reasons |= set(info["termination_reason"][ended])
    assert reasons <= REASONS
    return reasons


@pytest.mark.slow
@FUZZ
@given(scenario=st.sampled_from(list_scenarios()), seed=st.integers(0, 2**31),
       values=st.lists(extreme_or_nan, min_size=4 * VEHICLES, max_size=4 * VEHICLES))
def test_fuzzed_actions_never_give_a_non_finite_observation_or_reward(scenario, seed, values):
    env = QuadrotorVectorEnv(VEHICLES, scenario, invalid_actions="terminate")
    env.reset(seed=seed)
    actions = np.array(values).reshape(1, VEHICLES, 4)
    bad = ~np.isfinite(actions[0]).all(axis=1)
    reasons = _fly_and_check(env, actions)
    if bad.any():
        assert "invalid_action" in reasons


@pytest.mark.slow
@FUZZ
@given(scenario=st.sampled_from(list_scenarios()), seed=st.integers(0, 2**31),
       rotation=st.tuples(*[st.floats(-np.pi, np.pi)] * 3),
       rates=st.tuples(*[st.floats(-50, 50)] * 3),
       velocity=st.tuples(*[st.floats(-30, 30)] * 3),
       offset=st.tuples(*[st.floats(-3, 3)] * 3))
def test_fuzzed_initial_states_upside_down_included_end_with_reasons(scenario, seed, rotation,
                                                                      rates, velocity, offset):
    options = {"initial_rotation": exp(np.array(rotation)).tolist(),
               "initial_angular_velocity": rates, "initial_velocity": velocity,
               "initial_position": offset}
    try:  # a start at or below the floor is refused, naming it
        make_scenario(scenario, **options)
    except ValueError as refused:
        assert "at or below its floor" in str(refused)
        return
    env = ResidualVectorEnv(VEHICLES, scenario, options, base_controller="geometric-ndob")
    env.reset(seed=seed)
    actions = np.random.default_rng(seed).uniform(-1.5, 1.5, (7, VEHICLES, 4))
    _fly_and_check(env, actions)


def _mostly(valid, invalid):
    """Nine draws in ten from the valid range, so both paths are exercised."""
    return st.one_of(*[valid] * 9, invalid)


@FUZZ
@given(mass=_mostly(st.floats(0.5, 8.0), st.floats(-10, 0.5)),
       inertia=st.tuples(*[_mostly(st.floats(0.02, 0.3), st.floats(-0.2, 0.02))] * 3),
       thrust=_mostly(st.floats(12, 60), st.floats(-5, 12)))
def test_fuzzed_vehicle_parameters_are_accepted_or_named(mass, inertia, thrust):
    try:
        vehicle = get_vehicle("paper").with_changes(
            mass=mass, max_rotor_thrust=thrust,
            inertia=((inertia[0], 0, 0), (0, inertia[1], 0), (0, 0, inertia[2])))
    except ValueError as error:
        assert any(field in str(error) for field in ("mass", "inertia", "max_rotor_thrust",
                                                     "lift"))
        return
    env = QuadrotorEnv("hover-calm", {"vehicle": vehicle})
    env.reset(seed=0)
    for _ in range(50):
        obs, reward, terminated, truncated, _ = env.step(np.zeros(4))
        assert np.isfinite(obs).all() and np.isfinite(reward)
        if terminated or truncated:
            break


SCENARIO_FIELDS = ["dt", "duration", "substeps", "initial_position_noise",
                   "initial_attitude_noise", "floor_height", "actuation", "drag", "motor_lag"]


@FUZZ
@given(name=st.one_of(st.sampled_from(SCENARIO_FIELDS), st.text(max_size=12)),
       value=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-5, 5),
                       st.booleans(), st.text(max_size=8), st.none()))
def test_fuzzed_scenario_options_are_accepted_or_named(name, value):
    try:
        env = QuadrotorEnv("hover-calm", {name: value})
    except (ValueError, TypeError) as error:
        assert str(error)
        return
    obs, _ = env.reset(seed=0)
    assert np.isfinite(obs).all()


def test_invalid_actions_raise_by_default_and_can_end_just_that_episode():
    with pytest.raises(ValueError, match=r"must be finite.*invalid_actions='terminate'"):
        env = QuadrotorEnv()
        env.reset(seed=0)
        env.step([np.nan, 0, 0, 0])
    env = QuadrotorEnv(invalid_actions="terminate")
    env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step([0, np.inf, 0, 0])
    assert terminated and not truncated and info["termination_reason"] == "invalid_action"
    assert np.isfinite(obs).all() and np.isfinite(reward)
    vector = QuadrotorVectorEnv(3, invalid_actions="terminate")
    vector.reset(seed=0)
    actions = np.zeros((3, 4))
    actions[1, 2] = np.nan
    _, _, terminated, _, info = vector.step(actions)
    assert terminated.tolist() == [False, True, False]
    assert list(info["termination_reason"]) == ["", "invalid_action", ""]
    _, rewards, terminated, _, _ = vector.step(np.zeros((3, 4)))  # vehicle 1 autoresets alone
    assert not terminated.any() and rewards[1] == 0.0
    assert vector.core.step_count.tolist() == [2, 0, 2]
    with pytest.raises(ValueError, match=r"invalid_actions 'ignore'.*valid: raise, terminate"):
        QuadrotorVectorEnv(2, invalid_actions="ignore")


def test_reset_with_a_seed_mid_run_is_bit_identical_to_a_fresh_env():
    actions = np.random.default_rng(4).uniform(-0.3, 0.3, (120, 4))
    fresh = QuadrotorEnv("dryden-helix-gusts")
    used = QuadrotorEnv("dryden-helix-gusts")
    used.reset(seed=1)
    for action in actions[:77]:
        used.step(action)
    first_fresh, first_used = fresh.reset(seed=5)[0], used.reset(seed=5)[0]
    np.testing.assert_array_equal(first_fresh, first_used)
    for action in actions:
        np.testing.assert_array_equal(fresh.step(action)[0], used.step(action)[0])
