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


@pytest.mark.parametrize(("make", "owner", "typo", "meant"), [
    (lambda **kw: gym.make("QuadDOB/Hover-v2", **kw), "QuadrotorEnv", "action_mod",
     "action_mode"),
    (lambda **kw: gym.make("QuadDOB/HoverResidual-v2", **kw), "make_residual_env",
     "thrust_scal", "thrust_scale"),
    (lambda **kw: gym.make_vec("QuadDOB/Hover-v2", num_envs=2,
                               vectorization_mode="vector_entry_point", **kw),
     "QuadrotorVectorEnv", "action_mod", "action_mode"),
    (lambda **kw: gym.make_vec("QuadDOB/TrackResidual-v2", num_envs=2,
                               vectorization_mode="vector_entry_point", **kw),
     "ResidualVectorEnv", "thrust_scal", "thrust_scale"),
    (lambda **kw: __import__("quad_dob_training.rl.vec_env", fromlist=["x"]).QuadrotorSB3VecEnv(
        2, "hover-calm", base_controller="pid", **kw), "QuadrotorSB3VecEnv", "moment_scal",
     "moment_scale"),
])
def test_a_misspelled_keyword_is_answered_like_a_misspelled_value(make, owner, typo, meant):
    """As a user meets it: the typo, every valid keyword (the wrapped env's too, for the
    residual ones) and the closest, not a bare TypeError naming only the innermost class."""
    with pytest.raises(ValueError) as raised:
        make(**{typo: 1.0})
    message = str(raised.value)
    assert message.startswith(f"unknown keyword argument of {owner} {typo!r}; valid: ")
    assert message.endswith(f"(did you mean {meant!r}?)")
    assert "scenario_options" in message and "benchmark" in message
    make(**{meant: "thrust_moments" if meant == "action_mode" else 0.2}).close()  # spelled
    # right, the same call builds
