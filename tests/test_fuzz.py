"""The configuration fuzzer (``tests/fuzzer/``): a small profile finds no failure, and
its checks catch what they look for.

The profile: 40 configurations of seed 30 (ids, scenarios, options valid and not, single and
vector envs of both modes, NaN and out-of-range actions, two requests over the memory
budget), judged by what happened, not by the clock. ``python tests/fuzzer --configs 1000
--seed 0`` is the run by hand.
"""

from __future__ import annotations

import fuzzer  # tests/fuzzer/, beside this file
import gymnasium as gym
import numpy as np
import pytest

PROFILE_CONFIGS, PROFILE_SEED = 40, 30


@pytest.mark.slow
def test_a_small_profile_finds_no_failure():
    report = fuzzer.fuzz(PROFILE_CONFIGS, PROFILE_SEED, time_limit=None, isolated_timeout=None)
    print(report.summary())
    details = "\n".join(f.describe() for f in report.failures)
    assert not report.failures, f"{report.summary()}\n\nevery failure:\n{details}"
    # the profile exercises what it should: all three ways to build, refusals, flights
    assert report.configs == PROFILE_CONFIGS
    assert all(report.built[mode] for mode in fuzzer.MODES), report.built
    assert report.refused and report.vehicle_steps > 10_000 and report.isolated >= 2
    assert report.actions_refused and report.reasons["invalid_action"]


def _config(**changes):
    """A valid configuration: QuadDOB/Hover-v1, single env, 40 steps of random actions."""
    config = fuzzer.draw_config(0, 0)
    config.update(env_id="QuadDOB/Hover-v1", mode="single", num_envs=1, kwargs={},
                  actions={"kind": "uniform", "nan_rate": 0.0, "container": "float64",
                           "bad_rate": 0.0},
                  steps=40, to_the_end=False, reset_after_end=True, invalid=[], huge=[],
                  upstream_invalid=False, memory_hungry=False, replay=False)
    config.update(changes)
    return config


class _Broken(gym.Wrapper):
    """Breaks one rule from step ``at`` on."""

    def __init__(self, env, rule, at=5):
        super().__init__(env)
        self.rule, self.at, self.count = rule, at, 0

    def step(self, action):
        self.count += 1
        if self.rule == "swallow_nan":
            action = np.nan_to_num(np.asarray(action, dtype=float))
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.count >= self.at:
            if self.rule == "nan_observation":
                obs = obs * np.float32("nan")
            elif self.rule == "nan_info":
                info["disturbance_force"] = info["disturbance_force"] * np.nan
            elif self.rule == "type_error":
                raise TypeError("unsupported operand")
            elif self.rule == "drop_reason":
                info.pop("termination_reason", None)
        return obs, reward, terminated, truncated, info


def _categories(config, make):
    return {f.category for f in fuzzer.run_config(config, make=make).failures}


def test_the_checks_catch_what_they_look_for():
    def broken(rule):
        return lambda config: _Broken(fuzzer.build(config), rule)

    assert _categories(_config(), None) == set()
    assert _categories(_config(), broken("nan_observation")) == {"non_finite_observation"}
    assert _categories(_config(), broken("nan_info")) == {"non_finite_info"}
    assert _categories(_config(), broken("type_error")) == {"exception:TypeError"}
    # an episode of 0.3 s flown to its end, its reason removed
    short = _config(kwargs={"scenario_options": {"duration": 0.3}}, to_the_end=True)
    assert _categories(short, None) == set()
    assert _categories(short, broken("drop_reason")) == {"missing_termination_reason"}
    # a TimeLimit shorter than the scenario the user did not ask for (the default 1000
    # steps around a scenario made 2000 steps long by dt)
    longer = _config(kwargs={"scenario_options": {"dt": 0.005}})
    assert _categories(longer, lambda c: gym.wrappers.TimeLimit(fuzzer.build(c), 1000)) == {
        "early_truncation"}
    # a NaN action flown instead of refused, or not ending the episode
    nan = {"kind": "uniform", "nan_rate": 0.5, "container": "float64", "bad_rate": 0.0}
    assert _categories(_config(actions=nan), broken("swallow_nan")) == {
        "invalid_action_not_refused"}
    terminate = _config(actions=nan, kwargs={"invalid_actions": "terminate"})
    assert _categories(terminate, None) == set()
    assert _categories(terminate, broken("swallow_nan")) == {"invalid_action_not_ended"}


def test_a_configuration_is_reproducible_from_its_seed_and_index():
    assert repr(fuzzer.draw_config(7, 3)) == repr(fuzzer.draw_config(7, 3))
    assert repr(fuzzer.draw_config(7, 3)) != repr(fuzzer.draw_config(7, 4))
