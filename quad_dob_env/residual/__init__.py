"""Residual control: a base controller's command plus a policy's scaled residual.

- ``options``: ``ResidualOptions``, every option in one frozen record (with the table of
  what each does and which are experimental), ``split_residual_keys`` (flat keys -> the
  record, the one place), and ``RESIDUAL_PRESETS``, each shipped policy's options.
- ``command``: ``ResidualCommand``, base + residual for a whole ``QuadrotorBatch``; the
  vector env's ``base_controller=`` mode and ``ResidualActionWrapper`` both run it; the base
  behind ``BaseController``.
- ``modes``: the command's two modes, ``AccelerationMode`` and its guard.
- ``gate``: ``AuthorityGate``, the gate on the observed disturbance, its state and factor.
- ``floor_fade``: ``FloorFade``, the fade near the floor.
- ``observation``: the residual's observation entries, named (``RESIDUAL_ENTRIES``).
- ``residual_kernels``: the compiled per-vehicle command, reward and extra observation
  (``quad_dob_composition.fused`` runs them in its single pass).

May import the simulator's layers below the envs' faces (validation, the env core's kernels
and types); never ``quad_dob_baselines``, ``quad_dob_composition`` or ``quad_dob_training``:
the base comes in as an object.
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

__all__ = [
    "DEFAULT_BASE_CONTROLLER",
    "OPTION_NAMES",
    "RESIDUAL_MODES",
    "RESIDUAL_OBSERVATION_SIZE",
    "RESIDUAL_PRESETS",
    "BaseController",
    "ResidualCommand",
    "ResidualOptions",
    "split_residual_keys",
]
