"""Throughput of the simulator: single env via gym.make, the batched core, and the native
vector env with and without the geometric+NDOB base controller in the loop.

Run by hand (not part of the test suite): ``python benchmarks/throughput.py``. Prints
markdown tables; the README quotes them. Compilation happens before timing starts.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
import tracemalloc

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_composition import ResidualVectorEnv
from quad_dob_env.envs import QuadrotorBatch, QuadrotorVectorEnv
from quad_dob_env.scenarios import make_scenario

CALM, WINDY = "paper-none", "dryden-helix-gusts"


def single_env_steps_per_second(steps: int, scenario: str = CALM) -> float:
    """Random actions through ``gym.make`` (its checker wrappers included), resets counted."""
    env = gym.make("QuadDOB/Track-v1", scenario=scenario)
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


def vector_env(n: int, with_base: bool) -> QuadrotorVectorEnv:
    """``QuadDOB/Track-v1`` (paper helix) as N vehicles; with the base, the residual twin
    ``QuadDOB/TrackResidual-v1`` flown by geometric + NDOB (tuned observer)."""
    if with_base:
        return ResidualVectorEnv(n, CALM, base_controller="geometric-ndob:tuned")
    return QuadrotorVectorEnv(n, CALM)


def vector_env_steps_per_second(n: int, steps: int, with_base: bool) -> float:
    """Env-steps per second of ``QuadrotorVectorEnv.step`` (info dict and autoresets
    included), small random actions."""
    env = vector_env(n, with_base)
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-0.05, 0.05, (n, 4))
    for _ in range(3):  # compile and warm up
        env.step(actions)
    env.reset(seed=0)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(actions)
    return n * steps / (time.perf_counter() - start)


def memory_per_env(n: int, with_base: bool) -> float:
    """Bytes held per vehicle (numpy arrays, Python objects) by a reset, stepped env."""
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    env = vector_env(n, with_base)
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros((n, 4)))
    held = tracemalloc.get_traced_memory()[0] - before
    tracemalloc.stop()
    del env
    return held / n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--single-steps", type=int, default=50_000)
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[1, 64, 1024, 4096])
    parser.add_argument("--vector-sizes", type=int, nargs="+",
                        default=[1, 64, 256, 1024, 4096, 16384])
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
    print(f"| single env (gym.make QuadDOB/Track-v1, random actions, 100 Hz), steps/s | "
          f"{calm:,.0f} | {windy:,.0f} | {windy / calm:.2f} |")
    for n in args.batch_sizes:
        steps = max(10, min(1000, args.batch_vehicle_steps // n))
        calm, windy = (batch_steps_per_second(n, steps, s) for s in (CALM, WINDY))
        print(f"| batched core N = {n}, vehicle-steps/s | {calm:,.0f} | {windy:,.0f} | "
              f"{windy / calm:.2f} |")
    print(f"\nvector env (QuadrotorVectorEnv, {CALM}, next-step autoreset, info included); "
          "base = geometric-ndob:tuned run inside it for all N (QuadDOB/TrackResidual-v1)\n")
    print("| N | env-steps/s, bare | env-steps/s, base in the loop | base / bare | "
          "µs per env-step with base |")
    print("|---|---|---|---|---|")
    per_env, per_env_bare = {}, {}
    for n in args.vector_sizes:
        steps = max(20, min(2000, args.batch_vehicle_steps // n))
        bare = vector_env_steps_per_second(n, steps, with_base=False)
        based = vector_env_steps_per_second(n, steps, with_base=True)
        per_env[n], per_env_bare[n] = 1e6 / based, 1e6 / bare
        print(f"| {n} | {bare:,.0f} | {based:,.0f} | {based / bare:.2f} | {1e6 / based:.3f} |")
    print()
    for label, costs in (("with base", per_env), ("bare", per_env_bare)):
        flat = [cost for n, cost in costs.items() if n >= 256]
        if flat:
            print(f"per-env cost {label}, N >= 256: max / min = {max(flat) / min(flat):.2f}")
    for with_base in (False, True):
        print(f"memory per env ({'base in the loop' if with_base else 'bare'}, N = 4096): "
              f"{memory_per_env(4096, with_base) / 1024:.1f} KiB")


if __name__ == "__main__":
    main()
