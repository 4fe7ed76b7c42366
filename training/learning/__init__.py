"""Learning: the runs that train a model, and sweeps of runs, above the policies and the
evaluation because they fly policies to score them.

- ``train``: PPO, SAC or TD3 training, read top to bottom (``quad-dob train``).
- ``baseline_evaluation``: the evaluation against the base on held-out seeds during
  training, and the training curve.
- ``sweep``: grid and random sweeps of training or evaluation, resumable, on a process pool
  or Ray (``sweeps/``).

May import ``quad_dob_env``, ``quad_dob_composition``, ``quad_dob_baselines`` and the parts
of ``quad_dob_training`` below it (``rl``, ``policies``, ``evaluation``, ...; the order:
docs/design.md, "Layers"); not ``cli``, ``tuning``, ``wind_tunnel`` or ``paper``. Before
2026-12-06 these modules lived in ``rl``; their old names still import, with a
``DeprecationWarning`` naming the new one (``quad_dob_training.MOVED``).
"""
