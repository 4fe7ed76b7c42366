"""``ResidualQuadrotorVectorEnv``: the residual's vector face, a ``QuadrotorVectorEnv`` whose
every vehicle is flown by a base controller object plus the action as a residual.

It lives here, above the envs, because the residual's command needs the env's core and
kernels (``command``, ``residual_kernels``) while the plain vector env needs nothing of the
residual. ``quad_dob_composition.ResidualVectorEnv`` (a base by name) builds on it.
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.envs.vector_env import QuadrotorVectorEnv
from quad_dob_env.residual.command import ResidualCommand
from quad_dob_env.residual.options import ResidualOptions, split_residual_keys
from quad_dob_env.scenarios import Scenario
from quad_dob_env.validation import checked_keywords


class ResidualQuadrotorVectorEnv(QuadrotorVectorEnv):
    """N vehicles of one scenario, each flown by ``base_controller`` (a controller object;
    by name through ``quad_dob_composition.ResidualVectorEnv``, what the residual ids build),
    run once per step for the whole batch, plus the action as a residual (``ResidualCommand``:
    the command, the 16 extra observation entries, the reward). Everything else is
    ``QuadrotorVectorEnv``'s (its docstring: seeding, autoreset, ``info``).

    The residual's options come as ``residual_options`` (a ``ResidualOptions``: modes,
    scales, gate, floor fade, reward weights; its table lists them) or as the same names as
    flat keys (``thrust_scale=0.2``), as gym kwargs and configs give them; a key given both
    ways takes the flat value. ``fused_pass`` runs thrust-and-moment residuals in one compiled
    pass per step, ``attitude_loop`` the base's attitude law at a scenario's inner rate
    (``quad_dob_composition`` passes both). ``info`` adds ``base_thrust``, ``base_moment``,
    ``force_estimate`` and ``torque_estimate``, the reset info ``base_controller`` (its name
    and gains). ``reward_effort_weight`` defaults to 0 (the residual's own effort is
    ``residual_effort_weight``).
    """

    @checked_keywords(QuadrotorVectorEnv.__init__, ResidualOptions)
    def __init__(self, num_envs: int, scenario: str | Scenario = "paper-none",
                 scenario_options: dict[str, Any] | None = None, *, base_controller: Any,
                 fused_pass: Any = None, attitude_loop: Any = None,
                 residual_options: ResidualOptions | None = None,
                 **env_and_residual_keys: Any) -> None:
        # the residual's options as flat keys (gym kwargs, configs) become the record here;
        # the rest are the env's own
        residual_options = split_residual_keys(env_and_residual_keys, residual_options)
        env_keys = env_and_residual_keys
        if env_keys.get("reward_effort_weight") is None:
            env_keys["reward_effort_weight"] = 0.0
        super().__init__(num_envs, scenario, scenario_options, **env_keys)
        self.residual = ResidualCommand(self.core, base_controller, residual_options,
                                        fused_pass=fused_pass, attitude_loop=attitude_loop)
        self.base_controller = self.residual.controller.describe()
        self.set_observation_size(self.core.observation_size
                                  + self.residual.extra_observation.shape[1])

    def restart(self, indices: NDArray[np.intp]) -> None:
        """New episodes for vehicles ``indices``, with their first base command planned."""
        super().restart(indices)
        self.residual.restart(indices)

    def apply_actions(self, actions: NDArray) -> None:
        """The residuals added to the base's command, one step, the next command planned."""
        self.residual.step(actions)

    def rewards(self) -> NDArray[np.float64]:
        return self.residual.rewards

    def observations(self) -> NDArray[np.float32]:
        return self.residual.observation(self.core.obs)

    def info_arrays(self) -> dict[str, Any]:
        info = super().info_arrays()
        info.update(self.residual.info())
        return info

    def shared_reset_info(self) -> dict[str, Any]:
        # a copy: what a reset hands out is the caller's to change
        return {"base_controller": copy.deepcopy(self.base_controller)}


# the deprecated ``QuadrotorVectorEnv(base_controller=...)`` builds this face
QuadrotorVectorEnv.residual_face = ResidualQuadrotorVectorEnv
