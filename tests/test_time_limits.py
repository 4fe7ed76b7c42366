"""Episodes run to their scenario's end, whatever scenario_options make of its length; a
made env's spec says how long that is; and every client's way of asking for a shorter limit
ends episodes on the same step: TimeLimit and friends on single envs,
make_vec(max_episode_steps=N) in every vectorisation mode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import RecordEpisodeStatistics, TimeAwareObservation

import quad_dob_env
from quad_dob_env.envs import QuadrotorEnv
from quad_dob_env.scenarios import make_scenario

IDS = list(quad_dob_env.ENV_IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_a_made_env_reports_its_default_scenarios_length(env_id):
    steps = make_scenario(quad_dob_env.ENV_IDS[env_id]).steps
    assert gym.spec(env_id).max_episode_steps is None  # a registered one would cut (below)
    env = gym.make(env_id)
    assert env.spec.max_episode_steps == steps
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    assert envs.spec.max_episode_steps == steps
    assert gym.make(env_id, max_episode_steps=7).spec.max_episode_steps == 7


def _single_episode_length(env: gym.Env) -> tuple[int, dict]:
    env.reset(seed=0)
    for step in range(1, 10**6):
        _, _, terminated, truncated, info = env.step(np.zeros(4, np.float32))
        if terminated or truncated:
            return step, info
    raise AssertionError("the episode never ended")


# Before the fix gym.make wrapped a TimeLimit of the default 1,000 steps around these, so
# the halved dt ended at 5 s of a 10 s scenario and the longer duration at 10 s of 30 s.
@pytest.mark.parametrize(("env_id", "options", "steps"), [
    ("QuadDOB/HoverResidual-v1", {"dt": 0.005}, 2000),
    ("QuadDOB/TrackResidual-v1", {"duration": 30.0}, 3000),
])
def test_episodes_run_to_the_scenarios_end_when_options_change_its_length(env_id, options,
                                                                           steps):
    env = gym.make(env_id, scenario_options=options)
    assert env.spec.max_episode_steps == steps
    length, info = _single_episode_length(env)
    assert length == steps and info["termination_reason"] == "time_limit"
    assert info["time"] == pytest.approx(make_scenario(
        quad_dob_env.ENV_IDS[env_id], **options).duration)
    timed = TimeAwareObservation(gym.make(env_id, scenario_options=options))
    assert timed.max_timesteps == steps
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point",
                        scenario_options=options)
    assert envs.spec.max_episode_steps == steps and envs.core.episode_steps == steps
    envs.reset(seed=0)
    for _ in range(steps - 1):
        _, _, terminated, truncated, _ = envs.step(np.zeros((2, 4)))
        assert not (terminated.any() or truncated.any())
    *_, truncated, info = envs.step(np.zeros((2, 4)))
    assert truncated.all() and list(info["termination_reason"]) == ["time_limit"] * 2


def test_a_shorter_limit_the_user_asks_for_still_applies_to_a_longer_scenario():
    env = gym.make("QuadDOB/HoverResidual-v1", scenario_options={"dt": 0.005},
                   max_episode_steps=150)
    assert _single_episode_length(env)[0] == 150


@pytest.mark.parametrize("env_id", IDS)
def test_time_aware_observation_and_episode_statistics_work(env_id):
    env = RecordEpisodeStatistics(TimeAwareObservation(gym.make(env_id, max_episode_steps=3)))
    obs, _ = env.reset(seed=0)
    assert obs.shape == (env.observation_space.shape[0],) and env.observation_space.contains(obs)
    for step in range(3):
        obs, _, terminated, truncated, info = env.step(np.zeros(4, np.float32))
        assert obs[-1] == pytest.approx(step + 1)  # the time the wrapper appends
    assert truncated and not terminated and info["episode"]["l"] == 3


@pytest.mark.parametrize(("mode", "env_id"), [
    ("vector_entry_point", "QuadDOB/Hover-v1"), ("sync", "QuadDOB/Hover-v1"),
    ("vector_entry_point", "QuadDOB/TrackResidual-v1"), ("sync", "QuadDOB/TrackResidual-v1"),
    ("async", "QuadDOB/TrackResidual-v1")])  # async once: it starts a process per vehicle
def test_make_vec_max_episode_steps_truncates_at_n_in_every_mode(mode, env_id):
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode=mode, max_episode_steps=4)
    try:
        envs.reset(seed=0)
        flags = []
        for _ in range(5):
            _, _, terminated, truncated, _ = envs.step(np.zeros((2, 4)))
            flags.append((terminated.copy(), truncated.copy()))
        assert [bool(t.any()) for t, _ in flags] == [False] * 5
        assert [bool(t.all()) for _, t in flags[:4]] == [False, False, False, True]
        assert not flags[4][1].any()  # next-step autoreset: the step after starts afresh
    finally:
        envs.close()


def test_the_native_limit_is_named_and_never_longer_than_the_scenario():
    envs = gym.make_vec("QuadDOB/Hover-v1", num_envs=2, vectorization_mode="vector_entry_point",
                        max_episode_steps=10**6)  # longer than the scenario: it ends first
    assert envs.core.episode_steps == make_scenario("hover-calm").steps
    short = gym.make_vec("QuadDOB/Hover-v1", num_envs=2,
                         vectorization_mode="vector_entry_point", max_episode_steps=2)
    short.reset(seed=0)
    short.step(np.zeros((2, 4)))
    *_, info = short.step(np.zeros((2, 4)))
    assert list(info["termination_reason"]) == ["time_limit", "time_limit"]
    with pytest.raises(ValueError, match="max_episode_steps must be an integer >= 1"):
        gym.make_vec("QuadDOB/Hover-v1", num_envs=1, vectorization_mode="vector_entry_point",
                     max_episode_steps=0)


def test_a_family_flown_past_its_end_stays_finite_and_seeded():
    """Found by tests/fuzzer/: a reference family's table grew only when the step passed
    all its members' rows together, so a vehicle stepped past its episode's end without a
    reset read the next member's rows, and the last member's read past the table (NaN,
    different from run to run)."""
    scenario = make_scenario("random-lemniscates", duration=0.5)
    runs = []
    for _ in range(2):
        env = QuadrotorEnv(scenario)
        env.reset(seed=7)
        actions = np.random.default_rng(0).uniform(-0.05, 0.05, (3 * scenario.steps, 4))
        path = []
        for action in actions:  # on, past the time limit, without a reset
            obs, _, _, _, info = env.step(action)
            assert np.isfinite(obs).all() and np.isfinite(info["reference_position"]).all()
            path.append(info["reference_position"])
        runs.append(np.array(path))
    np.testing.assert_array_equal(*runs)
    member = env.core.reference_member[0]
    times = np.arange(1, 3 * scenario.steps + 1) * scenario.dt
    expected = scenario.trajectory.members[member].table(times)[:, 0]
    np.testing.assert_allclose(runs[0], expected, rtol=0, atol=1e-12)
