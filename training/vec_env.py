"""A stable-baselines3 ``VecEnv`` over the native batched core, for PPO on N vehicles.

SB3 does not take Gymnasium vector envs, and its convention differs: an episode that ends
is reset in the same step, the returned observation is the new episode's first, and the
last one goes in ``infos[i]["terminal_observation"]`` (``"TimeLimit.truncated"`` says
whether it was the time limit). This adapter drives a ``QuadrotorVectorEnv``'s core that
way, so ``PPO("MlpPolicy", QuadrotorSB3VecEnv(...))`` trains on N vehicles in one process.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.vec_env import VecEnv

from quad_dob_composition import ResidualVectorEnv, make_vector_env
from quad_dob_env.envs import QuadrotorVectorEnv
from quad_dob_env.validation import checked_keywords


class QuadrotorSB3VecEnv(VecEnv):
    """``num_envs`` vehicles of ``scenario`` as an SB3 VecEnv; other keyword arguments are
    ``QuadrotorVectorEnv``'s."""

    @checked_keywords(ResidualVectorEnv.__init__, QuadrotorVectorEnv.__init__)
    def __init__(self, num_envs: int, scenario: str = "paper-none", seed: int | None = None,
                 **env_kwargs: Any) -> None:
        self.vector_env = make_vector_env(num_envs, scenario, **env_kwargs)
        self.core = self.vector_env.core
        super().__init__(num_envs, self.vector_env.single_observation_space,
                         self.vector_env.single_action_space)
        self._seed = seed
        self._actions: NDArray | None = None

    def reset(self) -> NDArray[np.float32]:
        n, venv = self.num_envs, self.vector_env
        seeds = [None if self._seed is None else self._seed + i for i in range(n)]
        self._seed = None  # later resets continue each vehicle's generator
        venv.reseed(seeds)
        venv.restart(np.arange(n))
        self.reset_infos = [{} for _ in range(n)]
        return venv.observations()

    def step_async(self, actions: NDArray) -> None:
        self._actions = actions  # checked by the vector env's fly

    def step_wait(self) -> tuple[NDArray[np.float32], NDArray, NDArray, list[dict]]:
        venv, core = self.vector_env, self.core
        venv.fly(self._actions)
        rewards = venv.rewards().astype(np.float32)
        terminated, truncated = core.terminated, core.truncated
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        ended = np.flatnonzero(dones)
        if ended.size:
            last = venv.observations()[ended]
            for j, i in enumerate(ended):
                infos[i] = {"terminal_observation": last[j],
                            "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                            "termination_reason": core.termination_reason(i)}
            venv.restart(ended)
        return venv.observations(), rewards, dones.copy(), infos

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def close(self) -> None:
        self.vector_env.close()

    def _targets(self, indices: int | Iterable[int] | None) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        return [indices] if isinstance(indices, int) else list(indices)

    def get_attr(self, attr_name: str, indices: int | Iterable[int] | None = None) -> list[Any]:
        """An attribute of the vector env (shared by every vehicle), once per index."""
        value = getattr(self.vector_env, attr_name)
        return [value for _ in self._targets(indices)]

    def set_attr(self, attr_name: str, value: Any,
                 indices: int | Iterable[int] | None = None) -> None:
        raise AttributeError(f"the {self.num_envs} vehicles share one env; cannot set "
                             f"{attr_name!r} for some of them")

    def env_method(self, method_name: str, *method_args: Any,
                   indices: int | Iterable[int] | None = None, **method_kwargs: Any) -> list:
        method = getattr(self.vector_env, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._targets(indices)]

    def env_is_wrapped(self, wrapper_class: type,
                       indices: int | Iterable[int] | None = None) -> list[bool]:
        return [False for _ in self._targets(indices)]
