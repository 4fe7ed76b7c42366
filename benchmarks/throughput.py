"""Throughput of the simulator: single env via gym.make, and the batched core at several N.

Run by hand (not part of the test suite): ``python benchmarks/throughput.py``. Prints a
markdown table; the README quotes it. Compilation happens before timing starts.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.scenarios import make_scenario

CALM, WINDY = "paper-none", "dryden-helix-gusts"


def single_env_steps_per_second(steps: int, scenario: str = CALM) -> float:
    """Random actions through ``gym.make`` (its checker wrappers included), resets counted."""
    env = gym.make("QuadDOB/Track-v0", scenario=scenario)
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, 4)).astype(np.float32)
    for action in actions[:200]:  # compile and warm up
        env.step(action)
    env.reset(seed=0)
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def batch_steps_per_second(n: int, steps: int, scenario: str = CALM) -> float:
    """Vehicle-steps per second of ``QuadrotorBatch.step`` with N vehicles."""
    core = QuadrotorBatch(make_scenario(scenario), n)
    core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
    actions = np.random.default_rng(0).uniform(-0.05, 0.05, (n, 4))
    core.step(actions)  # compile
    core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
    start = time.perf_counter()
    for _ in range(steps):
        core.step(actions)
    return n * steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--single-steps", type=int, default=50_000)
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[1, 64, 1024, 4096])
    parser.add_argument("--batch-vehicle-steps", type=int, default=4_000_000,
                        help="vehicle-steps per batch size (steps = this / N, at most 1000)")
    args = parser.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}")
    print(f"\ncalm: {CALM} (no wind, no drag, instant motors); windy: {WINDY} (Dryden "
          "moderate + gusts, drag, motor lag)\n")
    calm, windy = (single_env_steps_per_second(args.single_steps, s) for s in (CALM, WINDY))
    print("| measurement | calm | windy | windy / calm |")
    print("|---|---|---|---|")
    print(f"| single env (gym.make QuadDOB/Track-v0, random actions, 100 Hz), steps/s | "
          f"{calm:,.0f} | {windy:,.0f} | {windy / calm:.2f} |")
    for n in args.batch_sizes:
        steps = max(10, min(1000, args.batch_vehicle_steps // n))
        calm, windy = (batch_steps_per_second(n, steps, s) for s in (CALM, WINDY))
        print(f"| batched core N = {n}, vehicle-steps/s | {calm:,.0f} | {windy:,.0f} | "
              f"{windy / calm:.2f} |")


if __name__ == "__main__":
    main()
