"""Composition: a controller inside the env's step. The one place that imports both the
simulator (``quad_dob_env``) and the controllers (``quad_dob_baselines``); the folder
``composition/`` installs as ``quad_dob_composition``. It never imports
``quad_dob_training``, which sits above it.

- ``bases``: a base controller by name (or object) for a vehicle, and the compiled pass
  that runs the geometric controller inside a residual step (``fused_pass_for``).
- ``fused``: that pass (residual, command, physics or the attitude law's ticks, sensors and
  estimator, observer, the next base command, the
  extra observation and reward, per vehicle).
- ``attitude_loop``: ``AttitudeLoop``, a controller's attitude law (``quad_dob_baselines
  .inner``) at a scenario's inner rate inside the env's step, installed on a core by
  whatever flies the controller there (the residual, ``ReferencePolicy``, evaluation).
- ``policy``: ``ReferencePolicy``, any controller as an SB3-style ``predict`` in a direct
  env (it refuses a residual one).
- ``envs``: what the registered ``QuadDOB/...Residual-v1`` ids build, by string entry
  point: ``make_residual_env`` (one vehicle) and ``ResidualVectorEnv`` (N vehicles), both
  taking ``base_controller`` by name; ``make_vector_env`` picks the plain or residual
  vector env; ``residual_command`` builds a ``ResidualCommand`` for a core.
- ``oracle``: the loop's floor, ``oracle:NAME``: a base whose observer is fed the
  simulator's true disturbance (``GivenDisturbance``), bound to its env's core.
- ``checks``: ``check_controller``, what a user's controller gets wrong against the
  interface, found by building it and flying it as the benchmark will.
"""

from quad_dob_composition.bases import fused_pass_for, make_base
from quad_dob_composition.checks import check_controller
from quad_dob_composition.envs import (
    ResidualVectorEnv,
    make_residual_env,
    make_vector_env,
    residual_command,
)
from quad_dob_composition.policy import ReferencePolicy

__all__ = [
    "ReferencePolicy",
    "ResidualVectorEnv",
    "check_controller",
    "fused_pass_for",
    "make_base",
    "make_residual_env",
    "make_vector_env",
    "residual_command",
]
