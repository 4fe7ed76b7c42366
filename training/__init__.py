"""Training, evaluation, the paper reproduction and the ``quad-dob`` command line.

The folder ``training/`` installs as ``quad_dob_training``; it sits on top and may import
``quad_dob_env`` and ``quad_dob_baselines``.

- ``cli``: ``quad-dob list | paper | train | evaluate | leaderboard | tune |
  check-controller | replay | sweep | hyperparams``; ``cli_checks``: the checks on what it is
  given; ``listing``: what ``quad-dob list`` prints (every name, every preset number's
  source).
- ``rollout``: ``Flight`` records and ``fly`` (controllers through scenarios, batched).
- ``metrics``: the scores every report uses (position; geodesic, tilt and heading
  errors); ``statistics``: bootstrap intervals and paired differences over seeds;
  ``plots``: the paper's PNG figures;
  ``report``: the self-contained interactive ``report.html``.
- ``paper``: the paper reproduction.
- ``vec_env``: the stable-baselines3 ``VecEnv`` adapter over the native vector env.
- ``train``: PPO or SAC training, read top to bottom; ``run_config``: the run as plain data
  (hyperparameters from ``hyperparams/ALGO.yml`` in rl-zoo3's schema, the versions and CPU
  it ran on); ``baseline_evaluation``: the evaluation against the base on held-out seeds
  during training, and the training curve; ``checkpoints``: the checkpoints a killed run
  resumes from, to the weights of a run never stopped; ``run_folder``: a run folder's
  identity (the run id in every file loaded again) and its lock.
- ``policies``: policies by name (controllers, ``py:`` ones, ``ALGO:PATH``, ``residual``)
  and flying them over many seeds; ``model_files``: model zips loaded without unpickling
  (and, for a run's own checkpoints, with); ``pretrained/`` holds the shipped residual
  policy.
- ``evaluate``: every policy on every scenario over seeds: tables with intervals and the
  paired difference to a baseline, distinct flights, the estimator's errors, bar plot,
  JSON; ``margins``: delay margins (the extra latency a policy's flights take);
  ``results``: ``evaluation.json`` (its schema in ``schemas/``) and leaderboards merged
  from many users' files.
- ``tune``: the one procedure that chooses the baselines' gains and the observer rates on
  tuning seeds.
- ``replay``: episodes rendered to GIF/MP4, side by side.
- ``sweep``: grid/random sweeps, resumable, on a process pool or Ray (``sweeps/``).
"""
