"""How often a residual policy's authority gate opens in calm air under each sensing.

The gate gives the residual authority only where the signal it reads (the observer's force
estimate, or with ``authority_signal="wind"`` its low-passed horizontal part) is above half
the gate (``quad_dob_env.residual.gate``). Fed a noisy estimate, the observer turns
velocity noise into apparent force; this counts the steps (after 2 s) on which the gate is
open at all, and the mean authority, as the env computed them, seeds 9001-9020 unless told.

Run by hand: ``python benchmarks/gate_under_noise.py`` (the shipped v1 policy on
``paper-none`` in v1's loop); ``--policy residual:PATH --scenario hover-calm --benchmark
v2`` measures another residual in another scenario and loop.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from quad_dob_composition import make_vector_env
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.policies import Policy, make_policy
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rollout import warm_up_copy

SENSINGS = ("ideal", "mocap", "gnss-imu")


def open_share(sensing: str, scenario: str = "paper-none", spec: str = "residual",
               benchmark: str = "v1", seeds: list[int] | None = None,
               warm_up: bool = False, policy: Policy | None = None) -> tuple[float, float]:
    """The share of steps after 2 s with the gate open, and the mean authority.
    ``warm_up``: fly the scenario's first few steps only (``rollout.warm_up_copy``), which
    compiles its kernels on a first run, and return zeros. ``policy``: ``spec`` already
    loaded."""
    seeds = seeds or list(range(9001, 9021))
    if policy is None:
        policy = make_policy(spec, benchmark=benchmark)  # bare residual: the benchmark's own
    flown = make_scenario(scenario, sensing=sensing, benchmark=benchmark)
    if warm_up:
        flown = warm_up_copy(flown)
    env = make_vector_env(len(seeds), flown, **policy.env_kwargs())
    obs, _ = env.reset(seed=seeds)
    residual = env.residual
    if residual.gate is None:
        raise ValueError(f"{spec!r} has no authority gate (authority_gate is None)")
    opened, authorities = [], []
    for step in range(flown.steps):
        obs, *_ = env.step(policy.act(obs))
        if step * flown.dt >= 2.0:  # the gate of the step just flown
            # the gate's own factor, not the floor fade's on top of it
            opened.append(residual.gate_authority > 0)
            authorities.append(residual.gate_authority.copy())
    if warm_up:
        return 0.0, 0.0
    return float(np.mean(opened)), float(np.mean(authorities))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default="residual", help="a residual policy spec")
    parser.add_argument("--scenario", default="paper-none", help="a calm scenario")
    parser.add_argument("--benchmark", default="v1", choices=("v1", "v2", "v3"))
    parser.add_argument("--seeds", default="9001-9020", help="a count or a range")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    print(f"gate_under_noise: {args.policy} on {args.scenario} ({args.benchmark}) under "
          f"{len(SENSINGS)} sensings x {len(seeds)} seeds", file=sys.stderr, flush=True)
    with Progress("loading", 1) as progress:  # a residual's load takes seconds
        progress.start(args.policy)
        policy = make_policy(args.policy, benchmark=args.benchmark)
        progress.done(policy.name)
    # each sensing's kernels compile on a first run: here, under a notice
    with compiling_notice():
        for sensing in SENSINGS:
            open_share(sensing, args.scenario, args.policy, args.benchmark, seeds, warm_up=True,
                       policy=policy)
    print("| sensing | gate open, share of steps after 2 s | mean authority |")
    print("|---|---|---|")
    with Progress("gate_under_noise", len(SENSINGS)) as progress:
        for sensing in SENSINGS:
            progress.start(sensing)
            share, authority = open_share(sensing, args.scenario, args.policy, args.benchmark,
                                          seeds, policy=policy)
            progress.done(f"gate open {share:.1%}")
            progress.print(f"| {sensing} | {share:.1%} | {authority:.3f} |")


if __name__ == "__main__":
    main()
