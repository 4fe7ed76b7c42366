"""The time limit is in the spec, and every client's way of asking for one ends episodes on
the same step: TimeLimit and friends on single envs, make_vec(max_episode_steps=N) in every
vectorisation mode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.wrappers import RecordEpisodeStatistics, TimeAwareObservation

import quad_dob_env
from quad_dob_env.scenarios import make_scenario

IDS = list(quad_dob_env.ENV_IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_every_id_carries_its_default_scenarios_length(env_id):
    spec = gym.spec(env_id)
    assert spec.max_episode_steps == make_scenario(quad_dob_env.ENV_IDS[env_id]).steps


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
