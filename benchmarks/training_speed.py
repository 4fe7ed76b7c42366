"""How fast PPO (stable-baselines3) learns on the native vector env, residual mode.

Run by hand: ``python benchmarks/training_speed.py [--timesteps 300000]``. Trains the
``QuadDOB/TrackResidual-v1`` recipe of ``training/hyperparams/ppo.yml`` (dryden-helix-gusts,
geometric-ndob:tuned base) without evaluations or checkpoints and prints timesteps/s: the
environment and the PPO update together, as a user sees it.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from pathlib import Path

import torch

from quad_dob_training.train import make_model, make_vec_env, resolve_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--timesteps", type=int, default=300_000)
    args = parser.parse_args()
    config = resolve_config("ppo", "residual", "QuadDOB/TrackResidual-v1", None,
                            args.timesteps, None, seed=0)
    with tempfile.TemporaryDirectory() as folder:
        model = make_model(config, make_vec_env(config), Path(folder) / "tb")
        model.learn(config["n_envs"] * config["algo_kwargs"].get("n_steps", 2048))  # warm up
        start = time.perf_counter()
        model.learn(args.timesteps, reset_num_timesteps=False)
        rate = args.timesteps / (time.perf_counter() - start)
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, torch {torch.__version__}")
    print(f"PPO on QuadDOB/TrackResidual-v1 ({config['env_kwargs']['scenario']}, base "
          f"{config['base_controller']}), {config['n_envs']} envs: {rate:,.0f} timesteps/s")


if __name__ == "__main__":
    main()
