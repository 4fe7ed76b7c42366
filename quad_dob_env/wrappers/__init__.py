"""Wrappers over the environments.

- ``residual``: ``ResidualActionWrapper``, a single env flown by a base controller plus the
  policy's scaled residual (``quad_dob_env.envs.residual.ResidualCommand``, which the vector
  env's ``base_controller=`` option runs too), and ``make_residual_env``, the entry point
  of the ``...Residual-v1`` ids.
"""

from quad_dob_env.wrappers.residual import ResidualActionWrapper, make_residual_env

__all__ = ["ResidualActionWrapper", "make_residual_env"]
