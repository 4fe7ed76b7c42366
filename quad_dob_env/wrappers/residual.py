"""``ResidualActionWrapper``: the single-env face of ``quad_dob_env.residual``.

Command, observation and reward: see ``quad_dob_env.residual``.
"""

from __future__ import annotations

import copy
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from quad_dob_env.envs.actions import screen_actions
from quad_dob_env.envs.step_kernels import OBSERVATION_BOUND
from quad_dob_env.residual import (
    OPTION_NAMES,
    ResidualCommand,
    ResidualOptions,
    split_residual_keys,
)
from quad_dob_env.validation import unknown_name_error

# the order the options were taken by position before ResidualOptions (2026-12-05)
LEGACY_POSITIONAL = ("thrust_scale", "moment_scale", "residual_effort_weight",
                     "authority_gate", "residual_mode", "acceleration_scale", "vertical_floor",
                     "attitude_loop")


def _legacy_options(values: tuple, keys: dict[str, Any], attitude_loop: Any) -> Any:
    """Options given by position, as before the record: moved into ``keys`` (the
    attitude loop returned), with a deprecation naming the replacement."""
    if len(values) > len(LEGACY_POSITIONAL):
        raise ValueError(f"ResidualActionWrapper takes at most {len(LEGACY_POSITIONAL)} "
                         f"options by position, got {len(values)}")
    warnings.warn("ResidualActionWrapper's options by position are deprecated: pass "
                  "residual_options=ResidualOptions(...) or the options by name",
                  DeprecationWarning, stacklevel=3)
    for name, value in zip(LEGACY_POSITIONAL, values, strict=False):
        if name == "attitude_loop":
            attitude_loop = value
        else:
            keys[name] = value
    return attitude_loop


class ResidualActionWrapper(gym.Wrapper):
    """A single ``QuadrotorEnv`` flown by ``base_controller`` plus the policy's residual
    (command, observation and reward: ``quad_dob_env.residual``).

    ``info`` also holds ``base_thrust``, ``base_moment`` (the base command for the coming
    step), ``force_estimate`` and ``torque_estimate`` (the observer's, zero without one).
    ``residual_options``: a ``ResidualOptions`` (the defaults without), or its fields by
    name (``thrust_scale=0.2``; a name given both ways takes that value).
    ``attitude_loop``: what runs the base's attitude law where the scenario has an inner
    loop (``quad_dob_composition`` passes ``AttitudeLoop.install``).
    """

    def __init__(self, env: gym.Env, base_controller: Any,
                 residual_options: ResidualOptions | None = None, *legacy_positional: Any,
                 attitude_loop: Any = None, **residual_keys: Any) -> None:
        super().__init__(env)
        core = getattr(env.unwrapped, "core", None)
        if core is None or core.n != 1:
            raise ValueError(f"ResidualActionWrapper wraps a single QuadrotorEnv, got {env!r}")
        if legacy_positional or not (residual_options is None
                                     or isinstance(residual_options, ResidualOptions)):
            attitude_loop = _legacy_options((residual_options, *legacy_positional),
                                            residual_keys, attitude_loop)
            residual_options = None
        options = split_residual_keys(residual_keys, residual_options)
        if residual_keys:
            raise unknown_name_error("keyword argument of ResidualActionWrapper",
                                     next(iter(residual_keys)),
                                     ["residual_options", "attitude_loop", *OPTION_NAMES])
        # the env steps itself, so the residual runs as separate stages around its step
        self.residual = ResidualCommand(core, base_controller, options,
                                        attitude_loop=attitude_loop)
        env.unwrapped.base_controller = self.residual.controller.describe()
        self.action_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.observation_space = gym.spaces.Box(
            -OBSERVATION_BOUND, OBSERVATION_BOUND,
            (core.observation_size + self.residual.extra_observation.shape[1],), np.float32)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[NDArray[np.float32], dict]:
        observation, info = self.env.reset(seed=seed, options=options)
        self.residual.restart(np.zeros(1, dtype=np.intp))
        return (self._observation(observation),
                {**self._info(info),  # a copy: what a reset hands out is the caller's
                 "base_controller": copy.deepcopy(self.env.unwrapped.base_controller)})

    def step(self, action: Any) -> tuple[NDArray[np.float32], float, bool, bool, dict]:
        residual, invalid = screen_actions(action, (4,), self.env.unwrapped.invalid_actions)
        observation, _, terminated, truncated, info = self.env.step(
            self.residual.command(residual[None])[0])
        if invalid.size:  # the env flew the base command; the fault ends the episode
            core = self.residual.core
            core.end_for_invalid_actions(invalid)
            terminated, truncated = True, False
            info["termination_reason"] = core.termination_reason(0)
        self.residual.record()
        self.residual.plan()
        return (self._observation(observation), float(self.residual.rewards[0]), terminated,
                truncated, self._info(info))

    def _observation(self, observation: NDArray[np.float32]) -> NDArray[np.float32]:
        return self.residual.observation(np.asarray(observation)[None])[0]

    def _info(self, info: dict) -> dict:
        return {**info, **{key: value[0] for key, value in self.residual.info().items()}}
