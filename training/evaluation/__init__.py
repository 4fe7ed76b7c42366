"""Evaluation: policies flown over scenarios and seeds, scored, compared and reported.

- ``evaluate``: every policy on every scenario over seeds (``quad-dob evaluate``): tables
  with intervals and the paired difference to a baseline, distinct flights, the
  estimator's errors, bar plot, JSON.
- ``metrics``: the scores every report uses (position; geodesic, tilt and heading errors).
- ``statistics``: bootstrap intervals and paired differences over seeds.
- ``margins``: delay margins (the extra latency a policy's flights take).
- ``ranking``: the one rule every ranking uses (flights lost, then RMS error) and the
  names a benchmark's strongest is chosen from.
- ``results``: ``evaluation.json`` (its schema in ``schemas/``) and leaderboards merged from
  many users' files.
- ``console``: the tables a command prints, fitted to 120 columns with ``±`` named.
- ``report``: the interactive ``report.html``.
- ``plots``: the PNG figures (the paper's, the evaluation's bars).

May import ``quad_dob_env``, ``quad_dob_composition``, ``quad_dob_baselines`` and the parts
of ``quad_dob_training`` below it (``progress``, ``rollout``, ``rl``, ``policies``; the order:
docs/design.md, "Layers"); not ``learning``, ``tuning``, ``wind_tunnel``, ``paper`` or ``cli``,
which score with it.
"""
