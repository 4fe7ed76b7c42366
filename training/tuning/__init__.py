"""Tuning the classical baselines.

- ``tune``: the one procedure that chooses the baselines' gains and the observer rates on
  tuning seeds, under the robustness margin (``quad-dob tune``).

May import ``quad_dob_env``, ``quad_dob_composition``, ``quad_dob_baselines`` and the parts
of ``quad_dob_training`` below it (``rollout``, ``rl``, ``policies``, ``evaluation``; the
order: docs/design.md, "Layers"); not ``cli``.
"""
