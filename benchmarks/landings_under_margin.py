"""Flights lost under issue 29's margin, on many seeds: which, and which of them the base kept.

Twenty seeds a scenario say little about a rare loss. This flies each policy on many seeds
of the given scenarios under the margin of the benchmark flown (``--benchmark``; v2's: 10 ms
of extra latency on every reading and a motor 1.5 times slower; v3's, its gain sets' tuning
margin ``benchmark_v3.TUNING_MARGIN``: 20 ms on the pose, unknown to the estimator, and the
same slower motor) and prints, per scenario and policy: the flights, the landings among
them (seeds whose vehicle draws a take-off and landing reference), the lost flights by seed
(landings marked), and how many of those the base (the first policy named) kept.
``--json FILE`` keeps every number.

``--dither A[,A...]`` adds a control: the base perturbed at random instead of by a policy.
It flies the env of the last residual named (its gate, floor fade and clip) with random
actions of standard deviation A in action units (A <= 0.5, so that the clip to [-1, 1]
seldom bites; the acceleration residual's 1 is ``acceleration_scale`` m/s²), each entry a
stationary Ornstein-Uhlenbeck process of correlation time ``--dither-time`` seconds (0:
white), ``--dither-draws`` noise streams per amplitude. Stream d is seeded d for every
amplitude and scenario (common random numbers: amplitudes differ in size, not in draw),
and a vehicle's noise follows its row in the batch, the seeds' order.

A policy's residual is smooth: match A and the time to its actions' RMS and step-to-step
change (``--dither-time`` ≈ 2 dt · RMS² / change²). If a perturbation of that size loses
landings the base kept as often as the policy does, the losses are the base's sensitivity
under the margin; if the dither keeps them, they are the policy's doing. A short
correlation time puts the same RMS at higher frequencies (the process's corner is
1 / (2π τ)), to ask which band of the residual does it.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.envs import QuadrotorVectorEnv
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.evaluation.metrics import flight_metrics
from quad_dob_training.policies import Policy, fly_policy, make_policy
from quad_dob_training.progress import Progress, compiling_notice, reported
from quad_dob_training.rollout import warm_up_copy
from quad_dob_training.tuning.tune import MARGINS  # each benchmark's: what its gains keep


def reference_kinds(scenario, seeds: list[int]) -> list[str]:
    """The kind of reference each seed's vehicle flies (the member drawn at its reset, the
    same whoever flies it), so that a flight lost mid-descent still counts as a landing."""
    env = QuadrotorVectorEnv(len(seeds), scenario)
    env.reset(seed=seeds)
    kinds = scenario.trajectory.kinds
    return [kinds[member] for member in env.core.reference_member]


@dataclass
class Dither(Policy):
    """A residual policy's env flown with random actions: per entry a stationary
    Ornstein-Uhlenbeck process of standard deviation ``amplitude`` and correlation time
    ``correlation_time`` [s] (0: white noise), clipped to the action box, from its own
    seeded stream."""

    amplitude: float = 0.0
    correlation_time: float = 0.0
    draw: int = 0
    stream: np.random.Generator | None = None
    memory: float = 0.0  # exp(-dt / correlation_time): how much of a step's noise the next keeps
    current: NDArray | None = None

    @classmethod
    def of(cls, residual: Policy, amplitude: float, correlation_time: float,
           draw: int) -> Dither:
        carried = {f.name: getattr(residual, f.name) for f in fields(Policy)}
        carried["name"] = (f"dither {amplitude:g}, {correlation_time:g} s (draw {draw}) on "
                           f"{residual.name}'s env")
        return cls(**carried, amplitude=amplitude, correlation_time=correlation_time,
                   draw=draw)

    def restart(self, dt: float) -> None:
        """The same noise from the first step of every scenario flown, at its step ``dt``."""
        self.stream = np.random.default_rng(self.draw)
        self.memory = (float(np.exp(-dt / self.correlation_time))
                       if self.correlation_time > 0 else 0.0)
        self.current = None

    def act(self, observations: NDArray[np.float32]) -> NDArray:
        shape = (len(observations), *self.model.action_space.shape)
        fresh = self.stream.normal(0.0, self.amplitude, shape)
        # the exact discrete OU step: the variance stays amplitude², from a stationary start
        self.current = (fresh if self.current is None else
                        self.memory * self.current + np.sqrt(1.0 - self.memory**2) * fresh)
        return np.clip(self.current, -1.0, 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policies", required=True,
                        help="comma-separated policy specs, the base first")
    parser.add_argument("--scenarios", default="random-tracks,heldout-tracks")
    parser.add_argument("--seeds", default="9400-9599")
    parser.add_argument("--dither", default="",
                        help="comma-separated amplitudes of the random-action control")
    parser.add_argument("--dither-time", type=float, default=0.0,
                        help="the dither's correlation time [s] (0: white)")
    parser.add_argument("--dither-draws", type=int, default=3,
                        help="noise streams per dither amplitude")
    parser.add_argument("--benchmark", choices=tuple(MARGINS), default="v2",
                        help="the loop flown, and its margin (default: %(default)s)")
    parser.add_argument("--json", help="write every number to this file")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    margin = MARGINS[args.benchmark]
    specs = args.policies.split(",")
    dithers = len([a for a in args.dither.split(",") if a]) * args.dither_draws
    print(f"landings_under_margin: {len(specs)} policies"
          + (f" and {dithers} dithers" if dithers else "")
          + f" x {len(args.scenarios.split(','))} scenarios x {len(seeds)} seeds, Benchmark "
          f"{args.benchmark}'s margin", file=sys.stderr, flush=True)
    # bare residual: the shipped policy of the benchmark flown
    policies = [make_policy(spec, benchmark=args.benchmark)
             for spec in reported(specs, "loading policies")]
    amplitudes = [float(a) for a in args.dither.split(",") if a]
    if amplitudes:
        residuals = [p for p in policies if p.model is not None and p.base is not None]
        if not residuals:
            raise ValueError("--dither flies a residual's env: name a residual policy in "
                             f"--policies (got {args.policies!r})")
        if any(not 0.0 < a <= 0.5 for a in amplitudes):
            raise ValueError(f"--dither amplitudes must lie in (0, 0.5] (action units, "
                             f"standard deviations the clip to [-1, 1] leaves nearly whole), "
                             f"got {args.dither!r}")
        if args.dither_draws < 1:
            raise ValueError(f"--dither-draws must be at least 1, got {args.dither_draws}")
        if not args.dither_time >= 0.0:
            raise ValueError(f"--dither-time must be >= 0 s, got {args.dither_time}")
        policies += [Dither.of(residuals[-1], a, args.dither_time, draw) for a in amplitudes
                     for draw in range(args.dither_draws)]
    names = args.scenarios.split(",")
    # a first run compiles the kernels here, under a notice (a dither flies the env of a
    # residual named, which compiles it)
    with compiling_notice():
        first = warm_up_copy(make_scenario(names[0], benchmark=args.benchmark, **margin))
        for policy in policies:
            if not isinstance(policy, Dither):
                fly_policy(policy, first, seeds)
    report: dict[str, dict[str, dict]] = {}
    print("| scenario | policy | flights | landings | lost | lost that the base kept | "
          "lost seeds (L: a landing) |")
    print("|---|---|---|---|---|---|---|")
    with Progress("landings_under_margin", len(names) * len(policies)) as progress:
        for name in names:
            scenario = make_scenario(name, benchmark=args.benchmark, **margin)
            kind_of = dict(zip(seeds, reference_kinds(scenario, seeds), strict=True))
            landings = sum(kind == "landing" for kind in kind_of.values())
            report[name] = {}
            base_lost: set[int] = set()
            for index, policy in enumerate(policies):
                spec = specs[index] if index < len(specs) else policy.name
                progress.start(f"{name}, {spec}")
                if isinstance(policy, Dither):
                    policy.restart(scenario.dt)
                flights = fly_policy(policy, scenario, seeds)
                lost = [seed for seed, f in zip(seeds, flights, strict=True)
                        if flight_metrics(f)["crashed"]]
                progress.done(f"{len(lost)} of {len(flights)} lost")
                if index == 0:
                    base_lost = set(lost)
                beyond = [seed for seed in lost if seed not in base_lost]
                report[name][spec] = {
                    "flights": len(flights), "landings": landings, "lost": lost,
                    "lost_landings": [s for s in lost if kind_of[s] == "landing"],
                    "lost_base_kept": beyond}
                shown = ", ".join(f"{seed}{' L' if kind_of[seed] == 'landing' else ''}"
                                  for seed in lost)
                progress.print(f"| {name} | {spec} | {len(flights)} | {landings} | "
                               f"{len(lost)} | {len(beyond) if index else '-'} | "
                               f"{shown or '-'} |")
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"seeds": seeds, "benchmark": args.benchmark, "scenario_options": margin,
                       "policies": specs + [p.name for p in policies[len(specs):]],
                       "scenarios": report}, file, indent=1)


if __name__ == "__main__":
    main()
