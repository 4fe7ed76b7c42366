"""``ResidualActionWrapper``: the single-env face of ``quad_dob_env.envs.residual``.

Command, observation and reward: see ``quad_dob_env.envs.residual``.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from quad_dob_env.envs.actions import screen_actions
from quad_dob_env.envs.kernels import OBSERVATION_BOUND
from quad_dob_env.envs.residual import ResidualCommand


class ResidualActionWrapper(gym.Wrapper):
    """A single ``QuadrotorEnv`` flown by ``base_controller`` plus the policy's residual
    (command, observation and reward: ``quad_dob_env.envs.residual``).

    ``info`` also holds ``base_thrust``, ``base_moment`` (the base command for the coming
    step), ``force_estimate`` and ``torque_estimate`` (the observer's, zero without one).
    ``attitude_loop``: what runs the base's attitude law where the scenario has an inner
    loop (``quad_dob_composition`` passes ``AttitudeLoop.install``).
    """

    def __init__(self, env: gym.Env, base_controller: Any,
                 thrust_scale: float = 0.1, moment_scale: float = 0.1,
                 residual_effort_weight: float = 0.01,
                 authority_gate: float | None = None, residual_mode: str = "thrust_moments",
                 acceleration_scale: float = 3.0, vertical_floor: float = 0.5,
                 attitude_loop: Any = None, residual_rate_weight: float = 0.0,
                 authority_signal: str = "force", lookahead: Sequence[float] = (),
                 floor_fade: Sequence[float] | None = None,
                 residual_cutoff: float | None = None) -> None:
        super().__init__(env)
        core = getattr(env.unwrapped, "core", None)
        if core is None or core.n != 1:
            raise ValueError(f"ResidualActionWrapper wraps a single QuadrotorEnv, got {env!r}")
        # the env steps itself, so the residual runs as separate stages around its step
        self.residual = ResidualCommand(core, base_controller, thrust_scale, moment_scale,
                                        residual_effort_weight,
                                        authority_gate=authority_gate,
                                        residual_mode=residual_mode,
                                        acceleration_scale=acceleration_scale,
                                        vertical_floor=vertical_floor,
                                        attitude_loop=attitude_loop,
                                        residual_rate_weight=residual_rate_weight,
                                        authority_signal=authority_signal,
                                        lookahead=lookahead, floor_fade=floor_fade,
                                        residual_cutoff=residual_cutoff)
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
