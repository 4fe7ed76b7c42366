"""Wrappers over the environments.

- ``residual``: ``ResidualActionWrapper``, a single env flown by a base controller object
  plus the policy's scaled residual (``quad_dob_env.residual.ResidualCommand``, which
  ``ResidualQuadrotorVectorEnv`` runs too). The ``...Residual-v1`` ids build it by name
  through ``quad_dob_composition.make_residual_env``.

The simulator's top folder: may import any of its folders and modules (``envs`` and
``residual`` included; docs/design.md, "Layers"); never ``quad_dob_baselines``,
``quad_dob_composition`` or ``quad_dob_training``.
"""

from quad_dob_env.wrappers.residual import ResidualActionWrapper

__all__ = ["ResidualActionWrapper"]
