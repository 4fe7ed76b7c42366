"""What a new user can find out from the env itself (part of issue 17)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import quad_dob_env  # noqa: F401
from quad_dob_composition import ReferencePolicy
from quad_dob_env.envs import QuadrotorEnv


def test_a_residual_env_says_which_base_flies_and_with_what_gains():
    env = gym.make("QuadDOB/TrackResidual-v1")
    _, info = env.reset(seed=0)
    base = env.unwrapped.base_controller
    assert base["name"] == "geometric-ndob:tuned" and base["Ks"] > 0
    assert info["base_controller"] == base
    assert gym.make("QuadDOB/Track-v1").unwrapped.base_controller is None
    vector = gym.make_vec("QuadDOB/HoverResidual-v1", num_envs=2,
                          vectorization_mode="vector_entry_point", base_controller="pid")
    _, info = vector.reset(seed=0)
    assert vector.base_controller["name"] == "pid"
    # per vehicle, as SyncVectorEnv merges each env's reset info
    assert list(info["base_controller"]["name"]) == ["pid", "pid"]
    assert info["_base_controller"].all()


def test_reference_policy_refuses_a_residual_env_and_says_what_to_use():
    with pytest.raises(ValueError, match=r"residual env .*'geometric-ndob:tuned'.*"
                                         r"QuadDOB/Hover-v1"):
        ReferencePolicy("pid", gym.make("QuadDOB/HoverResidual-v1"))
    ReferencePolicy("pid", gym.make("QuadDOB/Hover-v1"))  # a direct env is fine


def test_the_unwrapped_env_enforces_reset_before_step():
    env = QuadrotorEnv("hover-calm")
    with pytest.raises(gym.error.ResetNeeded, match="reset"):
        env.step(np.zeros(4, np.float32))
    env.reset(seed=0)
    env.step(np.zeros(4, np.float32))
