"""The residual envs by name: the entry points of the ``QuadDOB/...Residual-v1`` ids."""

from __future__ import annotations

from typing import Any

from quad_dob_composition.attitude_loop import AttitudeLoop
from quad_dob_composition.bases import fused_pass_for, make_base
from quad_dob_composition.oracle import bind_oracle
from quad_dob_env.benchmark import scenario_options_for
from quad_dob_env.envs import QuadrotorEnv, QuadrotorVectorEnv
from quad_dob_env.envs.core import QuadrotorBatch
from quad_dob_env.residual import (
    DEFAULT_BASE_CONTROLLER,
    ResidualCommand,
    ResidualOptions,
    ResidualQuadrotorVectorEnv,
    split_residual_keys,
)
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.validation import checked_keywords
from quad_dob_env.wrappers import ResidualActionWrapper


@checked_keywords(QuadrotorEnv.__init__, ResidualOptions)
def make_residual_env(base_controller: Any = DEFAULT_BASE_CONTROLLER,
                      residual_options: ResidualOptions | None = None,
                      **env_kwargs: Any) -> ResidualActionWrapper:
    """``ResidualActionWrapper(QuadrotorEnv(**env_kwargs))`` flown by ``base_controller``
    (a name or a controller), the env's own effort term off. The residual's options come
    as ``residual_options`` or as flat keys among ``env_kwargs`` (what a gym id passes)."""
    options = split_residual_keys(env_kwargs, residual_options)
    env_kwargs.setdefault("reward_effort_weight", 0.0)
    env = QuadrotorEnv(**env_kwargs)
    core = env.unwrapped.core
    base = make_base(base_controller, core.vehicle, core.scenario.loop.benchmark)
    bind_oracle(base, core)
    return ResidualActionWrapper(env, base, options, attitude_loop=AttitudeLoop.install)


class ResidualVectorEnv(ResidualQuadrotorVectorEnv):
    """``ResidualQuadrotorVectorEnv`` with ``base_controller`` by name (or object); the
    geometric base runs in one compiled pass per step unless ``compiled=False``. A named
    base flies the gains its name means in the scenario's benchmark, or in
    ``base_benchmark`` where given (a residual model's training benchmark)."""

    @checked_keywords(ResidualQuadrotorVectorEnv.__init__, QuadrotorVectorEnv.__init__,
                      ResidualOptions)
    def __init__(self, num_envs: int, scenario: Any = "paper-none",
                 scenario_options: dict[str, Any] | None = None,
                 base_controller: Any = DEFAULT_BASE_CONTROLLER, compiled: bool = True,
                 benchmark: str | None = None, base_benchmark: str | None = None,
                 **kwargs: Any) -> None:
        if base_controller is None:  # say what a residual env needs, not make_base's error
            raise ValueError("ResidualVectorEnv needs a base_controller (a controller name "
                             "such as 'geometric-ndob:tuned', or a controller); for direct "
                             "control use a direct id or QuadrotorVectorEnv")
        flown = make_scenario(scenario, **scenario_options_for(scenario_options, benchmark))
        base = make_base(base_controller, flown.vehicle,
                         base_benchmark or flown.loop.benchmark)
        # the scenario built here, not its name and options again: every build checks the
        # reference's feasibility
        super().__init__(num_envs, flown, base_controller=base,
                         fused_pass=fused_pass_for(base) if compiled else None,
                         attitude_loop=AttitudeLoop.install, **kwargs)
        bind_oracle(base, self.core)


def make_vector_env(num_envs: int, scenario: Any = "paper-none",
                    base_controller: Any = None, **kwargs: Any) -> QuadrotorVectorEnv:
    """The plain vector env without a base, the residual one with it."""
    if base_controller is None:
        return QuadrotorVectorEnv(num_envs, scenario, **kwargs)
    return ResidualVectorEnv(num_envs, scenario, base_controller=base_controller, **kwargs)


def residual_command(core: QuadrotorBatch, base_controller: Any = DEFAULT_BASE_CONTROLLER,
                     compiled: bool = True, residual_options: ResidualOptions | None = None,
                     **residual_keys: Any) -> ResidualCommand:
    """A ``ResidualCommand`` for ``core`` with ``base_controller`` by name (or object), its
    options as a record or flat keys."""
    options = split_residual_keys(residual_keys, residual_options)
    if residual_keys:
        raise ValueError(f"residual_command: unknown option {next(iter(residual_keys))!r}")
    base = make_base(base_controller, core.vehicle, core.scenario.loop.benchmark)
    bind_oracle(base, core)
    return ResidualCommand(core, base, options,
                           fused_pass=fused_pass_for(base) if compiled else None,
                           attitude_loop=AttitudeLoop.install)
