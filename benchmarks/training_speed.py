"""How fast PPO (stable-baselines3) learns on the native vector env, residual mode.

Run by hand: ``python benchmarks/training_speed.py [--timesteps 300000] [--env-id ID]``.
Trains the recipe of ``training/hyperparams/ppo.yml`` for the id (default
``QuadDOB/TracksResidual-v2``, issue 29's: random-tracks in Benchmark v2's randomised loop;
``QuadDOB/TrackResidual-v1`` is v1's dryden-helix-gusts recipe, the figures before issue 29)
without evaluations or checkpoints and prints timesteps/s: the
environment and the PPO update together, as a user sees it, and where the time went:
stepping the vehicles (the env), the rest of rollout collection (policy inference, buffer
writes) and the update (SB3's ``train``).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback

from quad_dob_training.learning.train import make_model, make_vec_env
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rl.run_config import resolve_config


class Stopwatch(BaseCallback):
    """Seconds spent collecting rollouts (everything between a rollout's start and end);
    with ``progress``, each iteration (a rollout and the update after it) reported there as
    the next rollout starts."""

    def __init__(self, progress: Progress | None = None, per_rollout: int = 0) -> None:
        super().__init__()
        self.collecting = 0.0
        self._start = 0.0
        self.progress, self.per_rollout = progress, per_rollout
        self.iteration = 0  # the iteration running

    def _on_rollout_start(self) -> None:
        self._start = time.perf_counter()
        if self.progress is not None:
            if self.iteration >= 1:  # the last one's update is over too
                self.progress.done()
            self.iteration += 1
            self.progress.start(f"iteration {self.iteration} ({self.per_rollout:,} timesteps)")

    def _on_rollout_end(self) -> None:
        self.collecting += time.perf_counter() - self._start

    def _on_step(self) -> bool:
        return True


def timed_env_steps(venv) -> list[float]:
    """Wrap the innermost env's ``step_wait`` to sum its seconds."""
    inner = venv
    while hasattr(inner, "venv"):
        inner = inner.venv
    spent = [0.0]
    step_wait = inner.step_wait

    def timed():
        start = time.perf_counter()
        result = step_wait()
        spent[0] += time.perf_counter() - start
        return result

    inner.step_wait = timed
    return spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--timesteps", type=int, default=300_000)
    parser.add_argument("--env-id", default="QuadDOB/TracksResidual-v2",
                        help="the ppo.yml recipe to train")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (recipe: 1)")
    parser.add_argument("--n-envs", type=int, default=None, help="vehicles (the recipe's)")
    parser.add_argument("--batch-size", type=int, default=None, help="the recipe's")
    parser.add_argument("--n-epochs", type=int, default=None, help="the recipe's")
    args = parser.parse_args()
    config = resolve_config("ppo", "residual", args.env_id, None, args.timesteps, args.n_envs,
                            seed=0)
    for key in ("batch_size", "n_epochs"):
        if getattr(args, key):
            config["algo_kwargs"][key] = getattr(args, key)
    per_rollout = config["n_envs"] * config["algo_kwargs"].get("n_steps", 2048)
    iterations = -(-args.timesteps // per_rollout)
    print(f"training_speed: PPO on {args.env_id}, one iteration of warm-up, then "
          f"{args.timesteps:,} timesteps timed ({iterations} iterations of {per_rollout:,})",
          file=sys.stderr, flush=True)
    with tempfile.TemporaryDirectory() as folder:
        # train's setup_process sets the recipe's 1; make_vec_env and make_model set none
        torch.set_num_threads(args.threads)
        venv = make_vec_env(config)
        with compiling_notice():  # a first run compiles the env's kernels on its first step
            venv.reset()
            venv.step(np.zeros((venv.num_envs, *venv.action_space.shape),
                               dtype=venv.action_space.dtype))
        with Progress("training_speed", 2 + iterations) as progress:
            progress.start("building the model")
            model = make_model(config, venv, Path(folder) / "tb")
            progress.done()
            progress.start("warm-up iteration (not timed)")
            model.learn(per_rollout)  # warm up
            progress.done()
            env_seconds = timed_env_steps(venv)
            stopwatch = Stopwatch(progress, per_rollout)
            start = time.perf_counter()
            model.learn(args.timesteps, reset_num_timesteps=False, callback=stopwatch)
            wall = time.perf_counter() - start
            progress.done()  # the last iteration's update
        rate = args.timesteps / wall
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, torch {torch.__version__}")
    print(f"PPO on {args.env_id} ({config['env_kwargs']['scenario']}, base "
          f"{config['base_controller']}), {config['n_envs']} envs, batch "
          f"{config['algo_kwargs']['batch_size']}, {config['algo_kwargs'].get('n_epochs', 10)} "
          f"epochs, {args.threads} torch thread(s): "
          f"{rate:,.0f} timesteps/s")
    update = wall - stopwatch.collecting
    print(f"of {wall:.1f} s: env steps {env_seconds[0]:.1f} s ({env_seconds[0] / wall:.0%}), "
          f"rest of collection (policy inference, buffer) "
          f"{stopwatch.collecting - env_seconds[0]:.1f} s "
          f"({(stopwatch.collecting - env_seconds[0]) / wall:.0%}), "
          f"update {update:.1f} s ({update / wall:.0%})")


if __name__ == "__main__":
    main()
