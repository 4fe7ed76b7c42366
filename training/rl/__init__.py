"""Reinforcement learning's plumbing: the SB3 adapter, model files and run folders, below the
policies (which load models through ``model_files``); the runs that train and sweep, which
fly policies, are ``quad_dob_training.learning``.

- ``run_config``: the run as plain data (hyperparameters from ``hyperparams/ALGO.yml`` in
  rl-zoo3's schema, the versions and CPU it ran on).
- ``vec_env``: ``QuadrotorSB3VecEnv``, the stable-baselines3 ``VecEnv`` adapter over the
  native vector env, with the training-only keys (``loop_randomization``).
- ``sb3_adapter``: ``make_sb3_vec_env(env_id, n, **overrides)``, that adapter built from an
  env id, exactly as the id builds it (exported here).
- ``loop_randomization``: ``LoopRandomization``, rl-zoo3's ``env_wrapper`` form of the
  training-only ``loop_randomization`` (each single env draws its own loop), and
  ``training_options``, which reads it back for ``quad-dob train``.
- ``foreign_models``: models saved by SB3 or rl-zoo3 with no project config (the env id
  supplies it), and rl-zoo3's ``vecnormalize.pkl`` read without unpickling.
- ``model_files``: model zips loaded without unpickling (and, for a run's own checkpoints,
  with); ``pretrained/`` holds the shipped residual policies.
- ``checkpoints``: the checkpoints a killed run resumes from, to the weights of a run never
  stopped.
- ``run_folder``: a run folder's identity (the run id in every file loaded again) and its
  lock.

Here too, light enough for the command line to import without the simulator: ``ALGORITHMS``
and ``HYPERPARAMS``.

May import ``quad_dob_env``, ``quad_dob_composition`` and ``quad_dob_baselines``; of
``quad_dob_training``, only what sits below it (the order: docs/design.md, "Layers"): not
``policies``, ``evaluation``, ``learning`` or anything above them. ``policies`` loads models
through ``model_files`` and flies them through ``vec_env``'s options.
"""

from pathlib import Path
from typing import Any

# the stable-baselines3 algorithms quad-dob train trains and ALGO:PATH loads (here, not in
# model_files, so the CLI can offer them without importing the simulator)
ALGORITHMS = ("ppo", "sac", "td3")
# the shipped hyperparameter files, one per algorithm (rl-zoo3's schema)
HYPERPARAMS = Path(__file__).parents[1] / "hyperparams"

# sha256 of the shipped residual policies' zips by the benchmark each was trained in
# (``residual:v1`` ...; ``model_files`` checks the zips against them), here so that merged
# leaderboards can name a shipped policy by a row's fingerprint without the simulator
SHIPPED_SHA256 = {
    "v1": "e75e4b59ef3afc351ddd0338b92b0eef63d56328f909f2d2300c88d5b7db34e5",
    "v2": "26da3f4ba1261843ff6e869a02e5633ada4b7d6048ffaa9e16563fcfde6b9662",
    "v3": "6be559a17e9c3545c6d06b9e32904f4d595de040967a0b135fc7d514d832695d",
    "v4": "351d45264cd636f838f0c4536fd953ea75b3d04094f82f7aedb4eeb12442aa48",
}

__all__ = ["ALGORITHMS", "HYPERPARAMS", "SHIPPED_SHA256", "make_sb3_vec_env"]


def __getattr__(name: str) -> Any:
    # imported when first asked for: the adapter needs the simulator, the CLI does not
    if name == "make_sb3_vec_env":
        from quad_dob_training.rl.sb3_adapter import make_sb3_vec_env

        return make_sb3_vec_env
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
