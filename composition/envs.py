"""The residual envs by name: the entry points of the ``QuadDOB/...Residual-v1`` ids."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from quad_dob_composition.attitude_loop import AttitudeLoop
from quad_dob_composition.bases import fused_pass_for, make_base
from quad_dob_env.benchmark import scenario_options_for
from quad_dob_env.envs import QuadrotorEnv, QuadrotorVectorEnv
from quad_dob_env.envs.core import QuadrotorBatch
from quad_dob_env.envs.residual import DEFAULT_BASE_CONTROLLER, ResidualCommand
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.validation import checked_keywords
from quad_dob_env.wrappers import ResidualActionWrapper


@checked_keywords(QuadrotorEnv.__init__)
def make_residual_env(base_controller: Any = DEFAULT_BASE_CONTROLLER, thrust_scale: float = 0.1,
                      moment_scale: float = 0.1, residual_effort_weight: float = 0.01,
                      authority_gate: float | None = None,
                      residual_mode: str = "thrust_moments", acceleration_scale: float = 3.0,
                      vertical_floor: float = 0.5, residual_rate_weight: float = 0.0,
                      authority_signal: str = "force", lookahead: Sequence[float] = (),
                      floor_fade: Sequence[float] | None = None,
                      residual_cutoff: float | None = None,
                      **env_kwargs: Any) -> ResidualActionWrapper:
    """``ResidualActionWrapper(QuadrotorEnv(**env_kwargs))`` flown by ``base_controller``
    (a name or a controller), the env's own effort term off."""
    env_kwargs.setdefault("reward_effort_weight", 0.0)
    env = QuadrotorEnv(**env_kwargs)
    core = env.unwrapped.core
    base = make_base(base_controller, core.vehicle, core.scenario.benchmark)
    return ResidualActionWrapper(env, base, thrust_scale, moment_scale, residual_effort_weight,
                                 authority_gate, residual_mode, acceleration_scale,
                                 vertical_floor, attitude_loop=AttitudeLoop.install,
                                 residual_rate_weight=residual_rate_weight,
                                 authority_signal=authority_signal, lookahead=lookahead,
                                 floor_fade=floor_fade, residual_cutoff=residual_cutoff)


class ResidualVectorEnv(QuadrotorVectorEnv):
    """``QuadrotorVectorEnv`` in residual mode with ``base_controller`` by name (or object);
    the geometric base runs in one compiled pass per step unless ``compiled=False``. A named
    base flies the gains its name means in the scenario's benchmark, or in
    ``base_benchmark`` where given (a residual model's training benchmark)."""

    @checked_keywords(QuadrotorVectorEnv.__init__)
    def __init__(self, num_envs: int, scenario: Any = "paper-none",
                 scenario_options: dict[str, Any] | None = None,
                 base_controller: Any = DEFAULT_BASE_CONTROLLER, compiled: bool = True,
                 benchmark: str | None = None, base_benchmark: str | None = None,
                 **kwargs: Any) -> None:
        if base_controller is None:  # the plain vector env would read None as "direct"
            raise ValueError("ResidualVectorEnv needs a base_controller (a controller name "
                             "such as 'geometric-ndob:tuned', or a controller); for direct "
                             "control use a direct id or QuadrotorVectorEnv")
        flown = make_scenario(scenario, **scenario_options_for(scenario_options, benchmark))
        base = make_base(base_controller, flown.vehicle, base_benchmark or flown.benchmark)
        super().__init__(num_envs, scenario, scenario_options, base_controller=base,
                         fused_pass=fused_pass_for(base) if compiled else None,
                         attitude_loop=AttitudeLoop.install, benchmark=benchmark, **kwargs)


def make_vector_env(num_envs: int, scenario: Any = "paper-none",
                    base_controller: Any = None, **kwargs: Any) -> QuadrotorVectorEnv:
    """The plain vector env without a base, the residual one with it."""
    if base_controller is None:
        return QuadrotorVectorEnv(num_envs, scenario, **kwargs)
    return ResidualVectorEnv(num_envs, scenario, base_controller=base_controller, **kwargs)


def residual_command(core: QuadrotorBatch, base_controller: Any = DEFAULT_BASE_CONTROLLER,
                     compiled: bool = True, **options: Any) -> ResidualCommand:
    """A ``ResidualCommand`` for ``core`` with ``base_controller`` by name (or object)."""
    base = make_base(base_controller, core.vehicle, core.scenario.benchmark)
    return ResidualCommand(core, base, fused_pass=fused_pass_for(base) if compiled else None,
                           attitude_loop=AttitudeLoop.install, **options)
