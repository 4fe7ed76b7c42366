"""Reinforcement learning: training runs, their files, and the SB3 adapter.

- ``train``: PPO, SAC or TD3 training, read top to bottom (``quad-dob train``).
- ``run_config``: the run as plain data (hyperparameters from ``hyperparams/ALGO.yml`` in
  rl-zoo3's schema, the versions and CPU it ran on).
- ``vec_env``: ``QuadrotorSB3VecEnv``, the stable-baselines3 ``VecEnv`` adapter over the
  native vector env, with the training-only keys (``loop_randomization``).
- ``model_files``: model zips loaded without unpickling (and, for a run's own checkpoints,
  with); ``pretrained/`` holds the shipped residual policies.
- ``baseline_evaluation``: the evaluation against the base on held-out seeds during
  training, and the training curve.
- ``checkpoints``: the checkpoints a killed run resumes from, to the weights of a run never
  stopped.
- ``run_folder``: a run folder's identity (the run id in every file loaded again) and its
  lock.
- ``sweep``: grid and random sweeps of training or evaluation, resumable, on a process pool
  or Ray (``sweeps/``).

Here too, light enough for the command line to import without the simulator: ``ALGORITHMS``
and ``HYPERPARAMS``.

May import ``quad_dob_env``, ``quad_dob_composition``, ``quad_dob_baselines``, the top
modules of ``quad_dob_training`` (``rollout``, ``policies``) and ``evaluation``; not
``cli``, ``tuning`` or ``wind_tunnel``. ``policies`` loads models through ``model_files``
and flies them through ``vec_env``'s options.
"""

from pathlib import Path

# the stable-baselines3 algorithms quad-dob train trains and ALGO:PATH loads (here, not in
# model_files, so the CLI can offer them without importing the simulator)
ALGORITHMS = ("ppo", "sac", "td3")
# the shipped hyperparameter files, one per algorithm (rl-zoo3's schema)
HYPERPARAMS = Path(__file__).parents[1] / "hyperparams"
