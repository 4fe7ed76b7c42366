"""Residual control: a base controller's command plus a policy's scaled residual.

- ``options``: ``ResidualOptions``, every option in one frozen record (with the table of
  what each does and which are experimental), ``split_residual_keys`` (flat keys -> the
  record, the one place), and ``RESIDUAL_PRESETS``, each shipped policy's options.
- ``command``: ``ResidualCommand``, base + residual for a whole ``QuadrotorBatch``;
  ``ResidualQuadrotorVectorEnv`` and ``ResidualActionWrapper`` both run it; the base
  behind ``BaseController``.
- ``vector_env``: ``ResidualQuadrotorVectorEnv``, the residual's vector face: a
  ``QuadrotorVectorEnv`` flown by a base controller object plus the residual.
- ``modes``: the command's two modes, ``AccelerationMode`` and its guard.
- ``gate``: ``AuthorityGate``, the gate on the observed disturbance, its state and factor.
- ``floor_fade``: ``FloorFade``, the fade near the floor.
- ``washout``: ``Washout``, the high-pass that leaves the residual's steady part to the
  observer.
- ``supervisor``: ``Supervisor`` and its ``SupervisorLimits``, the safety net that fades the
  residual on measured signals (body rate, attitude error, the residual's share), with
  hysteresis.
- ``loop_view``: ``LoopView``, what a residual sees of its loop beyond one instant: the last
  K steps' residuals and velocity errors, the measured thrust-path residual, the period.
- ``observation``: the residual's observation entries, named (``RESIDUAL_ENTRIES``, and the
  loop view's, ``loop_entries``), which ``ResidualOptions.observation_entries`` hands to the
  env's observation table.
- ``residual_kernels``: the compiled per-vehicle command, reward and extra observation
  (``quad_dob_composition.fused`` runs them in its single pass).

Sits above ``envs`` (its command drives the env's core and reuses its kernels) and may import
the simulator's folders and modules below it (the order: docs/design.md, "Layers"); never
``wrappers``, which sits above it, nor ``quad_dob_baselines``, ``quad_dob_composition`` or
``quad_dob_training``: the base comes in as an object.
"""

from quad_dob_env.residual.command import (
    DEFAULT_BASE_CONTROLLER,
    RESIDUAL_OBSERVATION_SIZE,
    BaseController,
    ResidualCommand,
)
from quad_dob_env.residual.options import (
    OPTION_NAMES,
    RESIDUAL_MODES,
    RESIDUAL_PRESETS,
    ResidualOptions,
    split_residual_keys,
)
from quad_dob_env.residual.vector_env import ResidualQuadrotorVectorEnv

__all__ = [
    "DEFAULT_BASE_CONTROLLER",
    "OPTION_NAMES",
    "RESIDUAL_MODES",
    "RESIDUAL_OBSERVATION_SIZE",
    "RESIDUAL_PRESETS",
    "BaseController",
    "ResidualCommand",
    "ResidualOptions",
    "ResidualQuadrotorVectorEnv",
    "split_residual_keys",
]
