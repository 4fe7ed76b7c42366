"""Soak: 10 million vector-env steps, memory at the start and at the end.

Run by hand: ``python benchmarks/soak.py [--steps 10000000] [--num-envs 4096]``. Flies
``dryden-helix-gusts`` (random disturbances, drag, motor lag) with geometric + NDOB as the
base of a residual and random residuals, so episodes crash, time out and autoreset all the
way through. Prints the resident memory after warm-up and at the end (it must stay flat
within 5 %), the episodes ended by each reason, and checks that no observation or reward
was ever non-finite.
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
import time

import numpy as np

from quad_dob_composition import ResidualVectorEnv
from quad_dob_training.progress import Progress, compiling_notice

CHUNKS = 10  # progress reported at each tenth of the steps


def resident_mib() -> float:
    with open("/proc/self/statm") as file:
        return int(file.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=10_000_000, help="vehicle-steps")
    parser.add_argument("--num-envs", type=int, default=4096)
    args = parser.parse_args()
    n = args.num_envs
    steps = args.steps // n
    print(f"soak: {steps * n:,} vehicle-steps ({n} vehicles x {steps:,} steps) on "
          "dryden-helix-gusts, after 200 steps of warm-up", file=sys.stderr, flush=True)
    rng = np.random.default_rng(0)
    reasons: collections.Counter = collections.Counter()
    with compiling_notice():  # a first run compiles the kernels here, and on the first step
        env = ResidualVectorEnv(n, "dryden-helix-gusts", base_controller="geometric-ndob:tuned",
                                 thrust_scale=0.3, moment_scale=0.3)
        env.reset(seed=0)
        env.step(rng.uniform(-1, 1, (n, 4)))
    chunk = max(1, -(-steps // CHUNKS))  # steps a unit of progress
    with Progress("soak", 1 + -(-steps // chunk)) as progress:
        progress.start("warm-up")
        for _ in range(199):  # warm up: fill the pools, reach steady state
            env.step(rng.uniform(-1, 1, (n, 4)))
        progress.done()
        start_memory, start = resident_mib(), time.perf_counter()
        for step in range(steps):
            if step % chunk == 0:
                progress.start(f"steps {step + 1:,}-{min(step + chunk, steps):,}")
            obs, rewards, terminated, truncated, info = env.step(rng.uniform(-1, 1, (n, 4)))
            if not (np.isfinite(obs).all() and np.isfinite(rewards).all()):
                raise SystemExit(f"non-finite observation or reward at step {step}")
            ended = terminated | truncated
            if ended.any():  # the key is there on steps where an episode ended
                reasons.update(info["termination_reason"][ended].tolist())
            if (step + 1) % chunk == 0 or step + 1 == steps:
                progress.done(f"{sum(reasons.values()):,} episodes ended so far")
        wall = time.perf_counter() - start
    end_memory = resident_mib()
    print(f"{steps * n:,} vehicle-steps ({n} vehicles x {steps:,} steps) in {wall:.0f} s "
          f"({steps * n / wall:,.0f} env-steps/s)")
    print(f"resident memory after warm-up {start_memory:.1f} MiB, at the end "
          f"{end_memory:.1f} MiB ({100 * (end_memory / start_memory - 1):+.2f} %)")
    print("episodes ended:", dict(reasons.most_common()))
    print("no observation or reward was ever non-finite")


if __name__ == "__main__":
    main()
