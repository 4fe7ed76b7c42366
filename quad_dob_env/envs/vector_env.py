"""``QuadrotorVectorEnv``: N vehicles as one Gymnasium vector env, stepped by the batched core."""

from __future__ import annotations

import warnings
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from quad_dob_env.benchmark import scenario_options_for
from quad_dob_env.compile_notice import announces_compiling
from quad_dob_env.envs.actions import INVALID_ACTION_MODES, screen_actions
from quad_dob_env.envs.core import EpisodeLimits, QuadrotorBatch, RewardWeights
from quad_dob_env.envs.limits import SpecWithEpisodeLength
from quad_dob_env.envs.rendering import FlightRenderer
from quad_dob_env.envs.step_kernels import OBSERVATION_BOUND, episode_ends_kernel
from quad_dob_env.envs.termination import TERMINATION_REASONS
from quad_dob_env.scenarios import Scenario, make_scenario
from quad_dob_env.validation import checked_keywords, unknown_name_error

RENDERED_VEHICLES = 4


class QuadrotorVectorEnv(SpecWithEpisodeLength, VectorEnv):
    """N quadrotors of one scenario, each the same as a ``QuadrotorEnv`` (spaces, reward,
    termination: see its docstring), stepped together in one compiled call.

    Seeding: ``reset(seed=s)`` gives vehicle i the generator of a single env reset with
    ``seed=s + i`` (a list gives one seed per vehicle), so vehicle i equals that single env
    step for step. Autoreset: Gymnasium's next-step mode by default, or
    ``autoreset_mode=AutoresetMode.SAME_STEP`` (``final_obs``, ``final_info``, as
    ``SyncVectorEnv`` in that mode). The step after a vehicle's
    episode ends resets it instead of stepping it: its observation is the new episode's
    first, with reward 0 and ``terminated = truncated = False``; its action is ignored.
    ``info`` holds arrays with a leading axis N (``time``, ``position_error``,
    ``disturbance_force``, ...), each with its ``_key`` mask as Gymnasium's vector envs give
    (all True: every vehicle reports them); ``termination_reason``, on a step where some
    episode ended, holds strings with the mask ``_termination_reason`` of those vehicles.
    ``sampled`` (what randomisation drew) comes at reset and after every autoreset, as a
    dict of (N,) arrays with masks and ``_sampled`` marking the vehicles that started an
    episode, as ``SyncVectorEnv`` merges it. ``max_episode_steps`` (what
    ``gym.make_vec(..., max_episode_steps=N)`` passes; the ids register none) truncates
    episodes after N steps, or at the scenario's end if that comes first, with reason
    ``time_limit``: the same step a ``TimeLimit`` wrapper ends a single env. Without it
    episodes end at the scenario's end, whatever ``scenario_options`` made of its length;
    ``spec.max_episode_steps`` reports the limit in force.

    A base controller plus the action as a residual is
    ``quad_dob_env.residual.ResidualQuadrotorVectorEnv`` (a controller object) or
    ``quad_dob_composition.ResidualVectorEnv`` (by name; what the residual ids build), a
    subclass that the residual layer, above this one, defines; ``residual`` and
    ``base_controller`` are None here. ``QuadrotorVectorEnv(..., base_controller=...)`` still
    builds that subclass, with a DeprecationWarning naming it.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 100,
                                          "autoreset_mode": AutoresetMode.NEXT_STEP}
    # what the deprecated ``QuadrotorVectorEnv(base_controller=...)`` builds: the residual's
    # vector face, which sits above the envs and names itself here when imported (importing
    # quad_dob_env imports it), so this layer needs no import of the residual
    residual_face: ClassVar[type[QuadrotorVectorEnv] | None] = None

    def __new__(cls, *args: Any, base_controller: Any = None, **kwargs: Any) -> Any:
        if base_controller is None or cls is not QuadrotorVectorEnv:
            return super().__new__(cls)
        warnings.warn("QuadrotorVectorEnv(base_controller=...) is deprecated: use "
                      "quad_dob_env.residual.ResidualQuadrotorVectorEnv (a controller object) "
                      "or quad_dob_composition.ResidualVectorEnv (a controller by name)",
                      DeprecationWarning, stacklevel=2)
        # Python then runs the face's __init__ with the same arguments
        return super().__new__(cls.residual_face)

    @checked_keywords()
    def __init__(self, num_envs: int, scenario: str | Scenario = "paper-none",
                 scenario_options: dict[str, Any] | None = None,
                 action_mode: str = "thrust_moments", rotation_representation: str = "matrix",
                 max_position_error: float = 5.0, max_tilt: float = np.pi / 2,
                 max_body_rate: float = 35.0, reward_position_scale: float = 0.25,
                 reward_effort_weight: float | None = None, render_mode: str | None = None,
                 base_controller: None = None, invalid_actions: str = "raise",
                 max_episode_steps: int | None = None,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 benchmark: str | None = None) -> None:
        if base_controller is not None:  # reached only by a subclass other than the face
            raise ValueError(f"{type(self).__name__} flies no base controller: use "
                             "quad_dob_env.residual.ResidualQuadrotorVectorEnv (a controller "
                             "object) or quad_dob_composition.ResidualVectorEnv (by name)")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r} is not supported by the vector env; "
                             "valid: None, rgb_array")
        if invalid_actions not in INVALID_ACTION_MODES:
            raise unknown_name_error("invalid_actions", invalid_actions, INVALID_ACTION_MODES)
        self.invalid_actions = invalid_actions
        self.render_mode = render_mode
        self.scenario = make_scenario(scenario, **scenario_options_for(scenario_options,
                                                                       benchmark))
        if reward_effort_weight is None:
            reward_effort_weight = 0.01
        self.core = QuadrotorBatch(
            self.scenario, num_envs, action_mode, rotation_representation,
            EpisodeLimits(max_position_error, max_tilt, max_body_rate),
            RewardWeights(reward_position_scale, reward_effort_weight),
        )
        self.core.set_time_limit(max_episode_steps)
        modes = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            self.autoreset_mode = None
        if self.autoreset_mode not in modes:
            given = getattr(autoreset_mode, "value", autoreset_mode)
            raise ValueError(f"autoreset_mode {given!r} is not supported; valid: "
                             + ", ".join(mode.value for mode in modes))
        # the residual face's (its command; the base's name and gains, also in the reset
        # info): None here, read by code that flies either kind
        self.residual: Any = None
        self.base_controller: dict[str, Any] | None = None
        self.num_envs = self.core.n
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.scenario.dt),
                         "autoreset_mode": self.autoreset_mode}
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.set_observation_size(self.core.observation_size)
        self._generators: list[np.random.Generator] = []
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._ended_count = 0
        self._no_reasons = np.full(self.num_envs, "", dtype=object)
        # the mask of keys every vehicle reports, shared by every step's info (read-only)
        self._every_vehicle = np.ones(self.num_envs, dtype=bool)
        self._every_vehicle.setflags(write=False)
        self._key_masks: dict[str, NDArray[np.bool_]] | None = None
        self._estimate_masks: dict[str, NDArray[np.bool_]] = {}
        self._renderer = None if render_mode is None else FlightRenderer(self.core)
        self._rendered = range(min(self.num_envs, RENDERED_VEHICLES))

    def set_observation_size(self, size: int) -> None:
        """The observation spaces for ``size`` columns (a residual face's are wider)."""
        self.single_observation_space = gym.spaces.Box(
            -OBSERVATION_BOUND, OBSERVATION_BOUND, (size,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

    @announces_compiling
    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[NDArray[np.float32], dict]:
        n = self.num_envs
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = [None if seed is None else int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"reset(seed=...) needs an int or {n} seeds, got {len(seeds)}")
        self.reseed(seeds)
        self.restart(np.arange(n))
        self.record_paths()
        self._needs_reset[:] = False
        self._ended_count = 0
        info = self._info(np.zeros(n, dtype=bool), 0)
        info.update(self._reset_info(np.arange(n)))
        return self.observations(), info

    def reseed(self, seeds: list[int | None]) -> None:
        """One generator per vehicle from ``seeds`` (None: fresh entropy); the vehicles'
        next episodes, and every autoreset after them, draw from these."""
        if len(seeds) != self.num_envs:
            raise ValueError(f"reseed needs {self.num_envs} seeds, got {len(seeds)}")
        self._generators = [seeding.np_random(s)[0] for s in seeds]

    def step(self, actions: Any) -> tuple[NDArray[np.float32], NDArray, NDArray, NDArray, dict]:
        if not self._generators:
            raise gym.error.ResetNeeded("call reset() before step()")
        self.step_vehicles(actions)
        restarted = self._needs_reset
        if self._ended_count:
            self.restart(np.flatnonzero(restarted))
        self.record_paths()
        n = self.num_envs
        rewards, ended = np.empty(n), np.empty(n, dtype=bool)
        terminated, truncated = np.empty(n, dtype=bool), np.empty(n, dtype=bool)
        self._ended_count = episode_ends_kernel(
            self.core.termination_code, self.core.step_count, self.core.episode_steps, restarted,
            self.rewards(), rewards, terminated, truncated, ended)
        info = self._info(ended, self._ended_count)
        if restarted.any():  # as Gymnasium's vector envs merge a reset's info
            info.update(self._reset_info(np.flatnonzero(restarted)))
        if self.autoreset_mode is AutoresetMode.SAME_STEP and self._ended_count:
            return self._reset_now(rewards, terminated, truncated, ended, info)
        self._needs_reset = ended
        return self.observations(), rewards, terminated, truncated, info

    def _reset_now(self, rewards: NDArray, terminated: NDArray, truncated: NDArray,
                   ended: NDArray[np.bool_], info: dict[str, Any]) -> tuple:
        """Same-step autoreset (Gymnasium 1.x): the ended vehicles start their new episode
        in this step; their last observation and info go in ``final_obs`` and
        ``final_info`` (masked by ``_final_obs``, ``_final_info``), and the step returns
        their new first observation and reset info, as ``SyncVectorEnv`` does."""
        indices = np.flatnonzero(ended)
        last = self.observations()
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in indices:
            final_obs[i] = last[i]
        final_info = {key: value for key, value in info.items() if not key.startswith("_")}
        for key in list(final_info):
            final_info[f"_{key}"] = ended.copy()
        self.restart(indices)
        self.record_paths()
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._ended_count = 0
        info = self._info(self._needs_reset, 0)
        info.update(self._reset_info(indices))
        info.update({"final_obs": final_obs, "_final_obs": ended.copy(),
                     "final_info": final_info, "_final_info": ended.copy()})
        return self.observations(), rewards, terminated, truncated, info

    # --- the stages, shared with quad_dob_training.rl.vec_env's SB3 adapter ---------------------
    def restart(self, indices: NDArray[np.intp]) -> None:
        """New episodes for vehicles ``indices``, from their own generators."""
        self.core.reset(indices, [self._generators[i] for i in indices])
        if self._renderer is not None:
            for i in indices:
                self._renderer.reset(int(i))

    def render(self) -> tuple[NDArray[np.uint8], ...] | None:
        """``rgb_array``: a frame (H, W, 3) for each of the first four vehicles (what is
        drawn: ``quad_dob_env.envs.rendering``)."""
        if self._renderer is None:
            return None
        return tuple(self._renderer.frame(i) for i in self._rendered)

    @announces_compiling
    def step_vehicles(self, actions: Any) -> None:
        """One step of every vehicle; NaN/inf rows raise or, with
        ``invalid_actions="terminate"``, fly at hover (a residual face: at the base command,
        a zero residual) and end those episodes."""
        actions, invalid = screen_actions(actions, (self.num_envs, 4), self.invalid_actions)
        self.apply_actions(actions)
        if invalid.size:
            self.core.end_for_invalid_actions(invalid)

    def apply_actions(self, actions: NDArray) -> None:
        """One step of every vehicle on screened actions (a residual face adds them to its
        base's command)."""
        self.core.step(actions)

    def record_paths(self) -> None:
        """The rendered vehicles' paths grow, once the batch is settled after a step."""
        if self._renderer is not None:
            for i in self._rendered:
                self._renderer.record(i)

    def rewards(self) -> NDArray[np.float64]:
        return self.core.rewards

    def observations(self) -> NDArray[np.float32]:
        return self.core.obs.copy()

    def info_arrays(self) -> dict[str, Any]:
        """This step's ``info`` entries, each an (N, ...) array (a residual face adds its
        own), before their masks."""
        return self.core.info_arrays()

    def shared_reset_info(self) -> dict[str, Any]:
        """Reset info every vehicle that starts an episode shares, one copy per call (none
        here; a residual face adds its ``base_controller``)."""
        return {}

    def _info(self, ended: NDArray[np.bool_], ended_count: int) -> dict[str, Any]:
        core = self.core
        info = self.info_arrays()
        if self._key_masks is None:  # the keys never change: their masks are made once
            self._key_masks = {f"_{key}": self._every_vehicle for key in info}
            # a nested dict carries its own masks, as Gymnasium's
            self._estimate_masks = {f"_{key}": self._every_vehicle for key in info["estimate"]}
        info.update(self._key_masks)  # every vehicle reports these
        info["estimate"].update(self._estimate_masks)
        if ended_count:  # as a single env reports it: only where an episode ended
            reasons = self._no_reasons.copy()
            for i in np.flatnonzero(ended):
                reasons[i] = core.termination_reason(i)
            info["termination_reason"] = reasons
            info["_termination_reason"] = ended.copy()
        return info

    def _reset_info(self, indices: NDArray[np.intp]) -> dict[str, Any]:
        """The reset info of the vehicles that started an episode: ``sampled`` (the draws of
        domain randomisation and random disturbances) and ``shared_reset_info``, merged as
        Gymnasium's vector envs merge each env's reset info (every value an (N, ...) array,
        nested dicts alike, each with its ``_key`` mask)."""
        merged: dict[str, Any] = {}
        # one copy for the call: the merge copies leaf values into its own arrays
        shared = self.shared_reset_info()
        for i in indices:
            vehicle = {"sampled": self.core.sampled[i], **shared}
            _add_vehicle_info(merged, vehicle, int(i), self.num_envs)
        return merged


def _add_vehicle_info(merged: dict[str, Any], info: dict[str, Any], i: int,
                      n: int) -> dict[str, Any]:
    """Vehicle ``i``'s ``info`` into ``merged``, in the layout of Gymnasium's vector infos."""
    for key, value in info.items():
        if isinstance(value, dict):
            array = _add_vehicle_info(merged.get(key, {}), value, i, n)
        else:
            array = merged.get(key)
            if array is None:
                if type(value) in (int, float, bool) or isinstance(value, np.number):
                    array = np.zeros(n, dtype=type(value))
                elif isinstance(value, np.ndarray):
                    array = np.zeros((n, *value.shape), dtype=value.dtype)
                else:
                    array = np.full(n, None, dtype=object)
            array[i] = value
        mask = merged.get(f"_{key}")
        if mask is None:
            mask = np.zeros(n, dtype=bool)
        mask[i] = True
        merged[key], merged[f"_{key}"] = array, mask
    return merged


__all__ = ["TERMINATION_REASONS", "QuadrotorVectorEnv"]
