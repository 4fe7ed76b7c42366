"""Throughput of the simulator: single env via gym.make, the batched core, the native
vector env with and without the geometric+NDOB base controller in the loop, and that vector
env under each sensing preset (``quad_dob_env.sensing``) beside the ideal one.

Run by hand (not part of the test suite): ``python benchmarks/throughput.py``. Prints
markdown tables; docs/speed.md quotes them. Compilation happens before timing starts.
``--sensing-only`` runs the sensing table alone; ``--loop-only`` the vehicle-loop table
(Benchmark v2: v1, part 1's sensing, each of part 2's factors on top of it, and the full
v2 and v3 loops, in one run); ``--benchmarks-only`` v1's, v2's and v3's whole loops alone;
``--v3-factors-only`` those and v3 with each of its own factors off (where v3's time goes).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
import tracemalloc
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_composition import ResidualVectorEnv
from quad_dob_env.benchmark import V2_INNER_RATE, V3_LOOP_FIELDS
from quad_dob_env.envs import QuadrotorBatch, QuadrotorVectorEnv
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.progress import Progress, compiling_notice

CALM, WINDY = "paper-none", "dryden-helix-gusts"
SENSING_PRESETS = ("mocap", "gnss-imu")  # compared with the ideal sensing (None)


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


def vector_env(n: int, with_base: bool, sensing: str | None = None,
               compiled: bool = True) -> QuadrotorVectorEnv:
    """``QuadDOB/Track-v1`` (paper helix) as N vehicles; with the base, the residual twin
    ``QuadDOB/TrackResidual-v1`` flown by geometric + NDOB (tuned observer). ``sensing``: a
    preset name (None: ideal); ``compiled=False`` runs the base through the staged path,
    which any non-ideal sensing takes anyway."""
    options = None if sensing is None else {"sensing": sensing}
    if with_base:
        return ResidualVectorEnv(n, CALM, scenario_options=options,
                                 base_controller="geometric-ndob:tuned", compiled=compiled)
    return QuadrotorVectorEnv(n, CALM, scenario_options=options)


def compiled_and_warm(env: QuadrotorVectorEnv) -> np.ndarray:
    """Small random actions for ``env``, after three steps that compile and warm it up."""
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-0.05, 0.05, (env.num_envs, 4))
    for _ in range(3):
        env.step(actions)
    return actions


def timed_env_steps_per_second(env: QuadrotorVectorEnv, actions: np.ndarray,
                               steps: int) -> float:
    """Env-steps per second of ``steps`` calls of ``env.step`` from a fresh reset (seed 0)."""
    env.reset(seed=0)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(actions)
    return env.num_envs * steps / (time.perf_counter() - start)


def vector_env_steps_per_second(n: int, steps: int, with_base: bool) -> float:
    """Env-steps per second of ``QuadrotorVectorEnv.step`` (info dict and autoresets
    included), small random actions."""
    env = vector_env(n, with_base)
    return timed_env_steps_per_second(env, compiled_and_warm(env), steps)


@dataclass(frozen=True)
class SensingVariant:
    """One row of the sensing table: the vector env with or without the base, a sensing
    preset (None: ideal) and, for the ideal base, whether its compiled fused pass runs."""

    with_base: bool
    sensing: str | None
    compiled: bool = True

    @property
    def label(self) -> str:
        base = "geometric-ndob:tuned" if self.with_base else "none (bare)"
        path = ""
        if self.with_base:
            path = "fused pass" if self.compiled and self.sensing is None else "staged"
        return f"{base} | {self.sensing or 'ideal'} | {path or '-'}"


def sensing_variants() -> list[SensingVariant]:
    """Base in the loop: ideal (fused pass), ideal through the staged path (what every
    non-ideal sensing runs, so the two costs separate), then each preset; bare: ideal, then
    each preset. The first of each group is its ratio's reference."""
    with_base = [SensingVariant(True, None), SensingVariant(True, None, compiled=False)]
    with_base += [SensingVariant(True, preset) for preset in SENSING_PRESETS]
    bare = [SensingVariant(False, None)]
    bare += [SensingVariant(False, preset) for preset in SENSING_PRESETS]
    return with_base + bare


def print_sensing_table(n: int, steps: int, repeats: int) -> None:
    """Every ``sensing_variants`` env at ``n`` vehicles, all built and warmed first, then
    timed in turn ``repeats`` times (the variants interleaved, so the machine's drift falls
    on all of them alike); the median of each, and its ratio to the ideal sensing's."""
    variants = sensing_variants()
    envs, actions = {}, {}
    rates: dict[SensingVariant, list[float]] = {variant: [] for variant in variants}
    with Progress("throughput sensing", len(variants) + repeats) as progress:
        for variant in variants:
            progress.start(f"building and warming {variant.label}")
            envs[variant] = vector_env(n, variant.with_base, variant.sensing, variant.compiled)
            actions[variant] = compiled_and_warm(envs[variant])
            progress.done()
        for repeat in range(repeats):
            progress.start(f"repeat {repeat + 1}/{repeats} of {len(variants)} variants")
            for variant in variants:
                rates[variant].append(timed_env_steps_per_second(envs[variant],
                                                                 actions[variant], steps))
            progress.done()
    print(f"\nsensing: vector env ({CALM}, N = {n}, {steps} steps from a reset, median of "
          f"{repeats} interleaved repeats); ratio to the ideal sensing of the same base\n")
    print("| base | sensing | base path | env-steps/s | spread (min-max) / median | / ideal | "
          "µs per env-step |")
    print("|---|---|---|---|---|---|---|")
    reference = {}
    for variant in variants:
        median = statistics.median(rates[variant])
        reference.setdefault(variant.with_base, median)
        spread = (max(rates[variant]) - min(rates[variant])) / median
        print(f"| {variant.label} | {median:,.0f} | {spread:.2f} | "
              f"{median / reference[variant.with_base]:.2f} | {1e6 / median:.3f} |")


# Benchmark v2's vehicle loop, factor by factor on top of part 1's mocap sensing
FULL_LOOP = {"sensing": "mocap", "speed_motors": True, "thrust_uncertainty": True,
             "rotor_aerodynamics": True}
LOOP_VARIANTS: tuple[tuple[str, dict, bool], ...] = (
    ("v1 (ideal sensing, fused pass)", {}, True),
    ("v1 through the staged path", {}, False),
    ("part 1: mocap sensing", {"sensing": "mocap"}, True),
    ("+ inner loop 200 Hz", {"sensing": "mocap", "inner_rate": 200.0}, True),
    ("+ inner loop 300 Hz", {"sensing": "mocap", "inner_rate": 300.0}, True),
    ("+ inner loop 400 Hz", {"sensing": "mocap", "inner_rate": 400.0}, True),
    ("+ speed motors", {"sensing": "mocap", "speed_motors": True}, True),
    ("+ thrust uncertainty", {"sensing": "mocap", "thrust_uncertainty": True}, True),
    ("+ rotor aerodynamics", {"sensing": "mocap", "rotor_aerodynamics": True}, True),
    (f"full v2 loop, inner {V2_INNER_RATE:g} Hz (v2's)", {**FULL_LOOP,
                                                          "inner_rate": V2_INNER_RATE}, True),
    ("full v2 loop, inner 300 Hz", {**FULL_LOOP, "inner_rate": 300.0}, True),
    ("full v2 loop, inner 400 Hz", {**FULL_LOOP, "inner_rate": 400.0}, True),
    ("full v3 loop (benchmark='v3')", {"benchmark": "v3"}, True),
)
# the benchmarks' whole loops alone (``--benchmarks-only``): issue 40's speed target is v3's
# env-steps/s at least half v1's in one run
BENCHMARK_VARIANTS: tuple[tuple[str, dict, bool], ...] = (
    LOOP_VARIANTS[0],
    ("full v2 loop (benchmark='v2')", {"benchmark": "v2"}, True),
    ("full v3 loop (benchmark='v3')", {"benchmark": "v3"}, True),
)

# where v3's time goes (``--v3-factors-only``): v3's loop with each of its own fields off
# (False: ``benchmark.loop_fields``' "off")
V3_FACTOR_VARIANTS: tuple[tuple[str, dict, bool], ...] = (
    *BENCHMARK_VARIANTS,
    *((f"v3, {field} off", {"benchmark": "v3", field: False}, True)
      for field in V3_LOOP_FIELDS),
)


def print_loop_table(n: int, steps: int, repeats: int,
                     variants: tuple[tuple[str, dict, bool], ...] = LOOP_VARIANTS) -> None:
    """Every one of ``variants``' residual envs (the geometric-ndob:tuned base, zero
    residual) on ``WINDY`` at ``n`` vehicles, built and warmed first, then timed
    interleaved ``repeats`` times; the median of each and its ratio to v1's."""
    envs, actions = [], [np.zeros((n, 4)) for _ in variants]
    rates: list[list[float]] = [[] for _ in variants]
    with Progress("throughput loop", len(variants) + repeats) as progress:
        for label, options, compiled in variants:
            progress.start(f"building and warming {label}")
            envs.append(ResidualVectorEnv(n, WINDY, scenario_options=options,
                                          base_controller="geometric-ndob:tuned",
                                          compiled=compiled))
            compiled_and_warm(envs[-1])
            progress.done()
        for repeat in range(repeats):
            progress.start(f"repeat {repeat + 1}/{repeats} of {len(variants)} loops")
            for k, env in enumerate(envs):
                rates[k].append(timed_env_steps_per_second(env, actions[k], steps))
            progress.done()
    print(f"\nvehicle loop: residual vector env ({WINDY}, base geometric-ndob:tuned, zero "
          f"residual, N = {n}, {steps} steps from a reset, median of {repeats} interleaved "
          "repeats); ratio to v1\n")
    print("| loop | env-steps/s | spread (min-max) / median | / v1 | µs per env-step |")
    print("|---|---|---|---|---|")
    reference = statistics.median(rates[0])
    for (label, _, _), measured in zip(variants, rates, strict=True):
        median = statistics.median(measured)
        spread = (max(measured) - min(measured)) / median
        print(f"| {label} | {median:,.0f} | {spread:.2f} | {median / reference:.2f} | "
              f"{1e6 / median:.3f} |")


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


def warm_up() -> None:
    """A few steps of a single env and of a small vector env with the base: a first run
    compiles the kernels here, under a notice (``progress.compiling_notice``), not in the
    first measurement's silence."""
    with compiling_notice():
        env = gym.make("QuadDOB/Track-v1", scenario=CALM)
        env.reset(seed=0)
        for _ in range(3):
            env.step(np.zeros(4, dtype=np.float32))
        compiled_and_warm(vector_env(2, with_base=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--single-steps", type=int, default=50_000)
    parser.add_argument("--batch-sizes", type=int, nargs="+", default=[1, 64, 1024, 4096])
    parser.add_argument("--vector-sizes", type=int, nargs="+",
                        default=[1, 64, 256, 1024, 4096, 16384])
    parser.add_argument("--batch-vehicle-steps", type=int, default=4_000_000,
                        help="vehicle-steps per batch size (steps = this / N, at most 1000)")
    parser.add_argument("--sensing-only", action="store_true",
                        help="run the sensing table alone (ideal vs the sensing presets)")
    parser.add_argument("--sensing-size", type=int, default=1024,
                        help="vehicles in the sensing table")
    parser.add_argument("--sensing-steps", type=int, default=300,
                        help="env steps per timed repeat in the sensing table")
    parser.add_argument("--sensing-repeats", type=int, default=7,
                        help="interleaved repeats per variant in the sensing table (median)")
    parser.add_argument("--loop-only", action="store_true",
                        help="run the vehicle-loop table alone (v1, sensing, v2's factors)")
    parser.add_argument("--benchmarks-only", action="store_true",
                        help="run the whole loops alone: v1, v2 and v3")
    parser.add_argument("--v3-factors-only", action="store_true",
                        help="run v1, v2 and v3 and v3 with each of its factors off")
    args = parser.parse_args()
    sections = ("the sensing table" if args.sensing_only else
                "the vehicle-loop table" if args.loop_only or args.benchmarks_only
                or args.v3_factors_only else
                "single env, batched core, vector env, sensing and vehicle-loop tables, memory")
    print(f"throughput: {sections}; each section reports its progress", file=sys.stderr,
          flush=True)
    warm_up()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}")
    if args.sensing_only:
        print_sensing_table(args.sensing_size, args.sensing_steps, args.sensing_repeats)
        return
    if args.loop_only or args.benchmarks_only or args.v3_factors_only:
        print_loop_table(args.sensing_size, args.sensing_steps, args.sensing_repeats,
                         BENCHMARK_VARIANTS if args.benchmarks_only else
                         V3_FACTOR_VARIANTS if args.v3_factors_only else LOOP_VARIANTS)
        return
    print(f"\ncalm: {CALM} (no wind, no drag, instant motors); windy: {WINDY} (Dryden "
          "moderate + gusts, drag, motor lag)\n")
    with Progress("throughput single env and core", 1 + len(args.batch_sizes)) as progress:
        progress.start("single env, calm and windy")
        calm, windy = (single_env_steps_per_second(args.single_steps, s) for s in (CALM, WINDY))
        progress.done()
        progress.print("| measurement | calm | windy | windy / calm |")
        progress.print("|---|---|---|---|")
        progress.print(f"| single env (gym.make QuadDOB/Track-v1, random actions, 100 Hz), "
                       f"steps/s | {calm:,.0f} | {windy:,.0f} | {windy / calm:.2f} |")
        for n in args.batch_sizes:
            progress.start(f"batched core N = {n}")
            steps = max(10, min(1000, args.batch_vehicle_steps // n))
            calm, windy = (batch_steps_per_second(n, steps, s) for s in (CALM, WINDY))
            progress.done()
            progress.print(f"| batched core N = {n}, vehicle-steps/s | {calm:,.0f} | "
                           f"{windy:,.0f} | {windy / calm:.2f} |")
    print(f"\nvector env (QuadrotorVectorEnv, {CALM}, next-step autoreset, info included); "
          "base = geometric-ndob:tuned run inside it for all N (QuadDOB/TrackResidual-v1)\n")
    print("| N | env-steps/s, bare | env-steps/s, base in the loop | base / bare | "
          "µs per env-step with base |")
    print("|---|---|---|---|---|")
    per_env, per_env_bare = {}, {}
    with Progress("throughput vector env", len(args.vector_sizes)) as progress:
        for n in args.vector_sizes:
            progress.start(f"N = {n}, bare and with base")
            steps = max(20, min(2000, args.batch_vehicle_steps // n))
            bare = vector_env_steps_per_second(n, steps, with_base=False)
            based = vector_env_steps_per_second(n, steps, with_base=True)
            per_env[n], per_env_bare[n] = 1e6 / based, 1e6 / bare
            progress.done()
            progress.print(f"| {n} | {bare:,.0f} | {based:,.0f} | {based / bare:.2f} | "
                           f"{1e6 / based:.3f} |")
    print()
    for label, costs in (("with base", per_env), ("bare", per_env_bare)):
        flat = [cost for n, cost in costs.items() if n >= 256]
        if flat:
            print(f"per-env cost {label}, N >= 256: max / min = {max(flat) / min(flat):.2f}")
    print_sensing_table(args.sensing_size, args.sensing_steps, args.sensing_repeats)
    print_loop_table(args.sensing_size, args.sensing_steps, args.sensing_repeats)
    print()
    with Progress("throughput memory", 2) as progress:
        for with_base in (False, True):
            label = "base in the loop" if with_base else "bare"
            progress.start(label)
            held = memory_per_env(4096, with_base)
            progress.done()
            progress.print(f"memory per env ({label}, N = 4096): {held / 1024:.1f} KiB")


if __name__ == "__main__":
    main()
