"""Each shipped gain set's delay margin, as Benchmark v3's issue defines it: the minimum over
``quad-dob tune``'s tuning scenarios, on its tuning seeds (100-109), of the largest extra
latency of ``margins.DELAY_GRID`` that keeps every flight.

``python benchmarks/gain_set_delay_margins.py [--benchmark v3|v4] [--vehicle neural-fly]
[--on pose|readings] [--controllers a,b]`` prints per name the margin on each tuning
scenario and their minimum. The latency goes where the benchmark's own tuning margin puts it
unless ``--on`` says otherwise (v3: on the pose fix, unknown to the estimator; v2: on every
reading). The tuning scenarios and seeds are the ones the sets were chosen on: these
figures describe the sets' robustness, not their precision on unseen seeds.
"""

from __future__ import annotations

import argparse
import sys

from quad_dob_training.evaluation.margins import (
    DELAY_GRID,
    DELAY_PATHS,
    benchmark_delay_path,
    delay_margin,
)
from quad_dob_training.policies import Policy, fly_policy
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rollout import warm_up_copy
from quad_dob_training.tuning.tune import (
    DEFAULT_CONTROLLERS,
    TUNING_SCENARIOS,
    TUNING_SEEDS,
    tuning_scenario,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--benchmark", default="v3", choices=("v2", "v3", "v4"))
    parser.add_argument("--vehicle", default="neural-fly")
    parser.add_argument("--on", choices=tuple(DELAY_PATHS), default=None)
    parser.add_argument("--controllers", default=None)
    args = parser.parse_args()
    path = args.on or benchmark_delay_path(args.benchmark)
    names = ([name.strip() for name in args.controllers.split(",") if name.strip()]
             if args.controllers else list(DEFAULT_CONTROLLERS[args.benchmark]))
    scenarios = TUNING_SCENARIOS[args.benchmark]
    print(f"gain_set_delay_margins: {len(names)} gain sets x {len(scenarios)} tuning scenarios "
          f"x {len(TUNING_SEEDS)} seeds, up to {len(DELAY_GRID)} latencies each",
          file=sys.stderr, flush=True)
    # a first run compiles the kernels here, under a notice, not in the first unit's silence
    with compiling_notice():
        first = warm_up_copy(tuning_scenario(scenarios[0], args.benchmark, args.vehicle))
        for name in names:
            fly_policy(Policy(name, name), first, list(TUNING_SEEDS))
    print(f"Delay margins on the {path} ({args.benchmark}, {args.vehicle}, tuning seeds "
          f"{TUNING_SEEDS[0]}-{TUNING_SEEDS[-1]}, grid "
          f"{', '.join(f'{1000 * v:g}' for v in DELAY_GRID)} ms)\n")
    print("| name | " + " | ".join(scenarios) + " | minimum |")
    print("|---|" + "---|" * (len(scenarios) + 1))
    with Progress("gain_set_delay_margins", len(names) * len(scenarios)) as progress:
        for name in names:
            found = {}
            for scenario in scenarios:
                progress.start(f"{name}, {scenario}")
                found[scenario] = delay_margin(Policy(name, name), tuning_scenario(
                    scenario, args.benchmark, args.vehicle), list(TUNING_SEEDS), path=path)
                progress.done(found[scenario].describe())
            # a scenario that loses flights at the grid's first value has no margin at all
            lowest = min(found.values(), key=lambda m: -1.0 if m.margin is None else m.margin)
            limit = ", ".join(s for s, m in found.items() if m.margin == lowest.margin)
            progress.print(f"| {name} | " + " | ".join(m.describe() for m in found.values())
                           + f" | {lowest.describe()} ({limit}) |")


if __name__ == "__main__":
    main()
