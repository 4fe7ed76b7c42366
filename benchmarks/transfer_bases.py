"""How much of a shipped residual's transfer is its base's: each residual flown in another
benchmark beside its base alone, as the residual loads it (the gains of the benchmark the
residual was trained in, the residual's env options, the residual zero).

A residual trained in v2 and flown in v3 keeps its base at v2's gains. Those gains were
tuned with less lag, and v3's own classical sets were tuned under v3's margin. Comparing a
residual with v3's baselines alone mixes two changes: the policy's correction and its
base's gains. This prints, per scenario, the residual, its base as it loads, and the
residual's paired change against that base with the 95 % bootstrap interval.

Run by hand: ``python benchmarks/transfer_bases.py --residuals residual:v1,residual:v2
--benchmark v3 --seeds 9001-9020``. ``--json FILE`` keeps every number.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

import numpy as np

from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.evaluate import SUITES, parse_seeds
from quad_dob_training.evaluation.metrics import flight_metrics
from quad_dob_training.evaluation.statistics import bootstrap_mean, paired_difference
from quad_dob_training.policies import fly_policy, make_policy
from quad_dob_training.progress import Progress, compiling_notice, reported
from quad_dob_training.rollout import warm_up_copy


def settled_rms(policy, scenario, seeds) -> tuple[np.ndarray, np.ndarray]:
    """Per seed: RMS position error after the settle time [m], and whether it was lost."""
    metrics = [flight_metrics(flight) for flight in fly_policy(policy, scenario, seeds)]
    return (np.array([m["rms_position_settled"] for m in metrics]),
            np.array([bool(m["crashed"]) for m in metrics]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--residuals", default="residual:v1,residual:v2")
    parser.add_argument("--benchmark", default="v3")
    parser.add_argument("--scenarios", default="", help="comma-separated; default the suite")
    parser.add_argument("--seeds", default="9001-9020")
    parser.add_argument("--json", help="write every number to this file")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    names = (args.scenarios.split(",") if args.scenarios else
             [name for family in SUITES[args.benchmark].values() for name in family])
    specs = args.residuals.split(",")
    print(f"transfer_bases: {len(specs)} residuals and their bases x {len(names)} scenarios x "
          f"{len(seeds)} seeds, Benchmark {args.benchmark}", file=sys.stderr, flush=True)
    # bare residual: the shipped policy of the benchmark flown
    residuals = [make_policy(spec, benchmark=args.benchmark)
             for spec in reported(specs, "loading residuals")]
    # the base alone, as the residual loads it: the same env, the residual held at zero
    bases = [dataclasses.replace(policy, model=None,
                                 name=f"{policy.base} at {policy.base_benchmark} gains")
             for policy in residuals]
    print("| scenario | " + " | ".join(
        f"{r.name} (mm) | its base at {r.base_benchmark} gains (mm) | change [95 % CI] | lost "
        "(residual / base)" for r in residuals) + " |")
    print("|---|" + "---|---|---|---|" * len(residuals))
    # a first run compiles the kernels here, under a notice
    with compiling_notice():
        first = warm_up_copy(make_scenario(names[0], benchmark=args.benchmark))
        for policy in (*residuals, *bases):
            fly_policy(policy, first, seeds)
    report = {}
    with Progress("transfer_bases", 2 * len(names) * len(residuals)) as progress:
        for name in names:
            scenario = make_scenario(name, benchmark=args.benchmark)
            cells, report[name] = [], {}
            for residual, base in zip(residuals, bases, strict=True):
                progress.start(f"{name}, {residual.name}")
                mine, lost = settled_rms(residual, scenario, seeds)
                progress.done(f"{1e3 * mine.mean():.1f} mm")
                progress.start(f"{name}, {base.name}")
                theirs, base_lost = settled_rms(base, scenario, seeds)
                progress.done(f"{1e3 * theirs.mean():.1f} mm")
                difference = paired_difference(mine, theirs)
                scale = 100 / theirs.mean()
                report[name][residual.name] = {
                    "residual": bootstrap_mean(mine)._asdict(),
                    "base": bootstrap_mean(theirs)._asdict(),
                    "paired": difference._asdict(), "lost": int(lost.sum()),
                    "base_lost": int(base_lost.sum())}
                cells.append(f"{1e3 * mine.mean():.1f} | {1e3 * theirs.mean():.1f} | "
                             f"{scale * difference.mean:+.0f} % [{scale * difference.low:+.0f}, "
                             f"{scale * difference.high:+.0f}] | {int(lost.sum())} / "
                             f"{int(base_lost.sum())}")
            progress.print(f"| {name} | " + " | ".join(cells) + " |")
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"seeds": seeds, "benchmark": args.benchmark, "scenarios": report}, file,
                      indent=1)


if __name__ == "__main__":
    main()
