"""Flights lost under issue 29's margin, on many seeds: which, and which of them the base kept.

Twenty seeds a scenario say little about a rare loss. This flies each policy on many seeds
of the given scenarios under the margin (10 ms of extra latency, a motor 1.5 times slower,
Benchmark v2's loop) and prints, per scenario and policy: the flights, the landings among
them (seeds whose vehicle draws a take-off and landing reference), the lost flights by seed
(landings marked), and how many of those the base (the first policy named) kept.
``--json FILE`` keeps every number.

Run by hand, e.g. ``python benchmarks/landings_under_margin.py --policies
geometric-ndob:tuned,residual:v2 --scenarios random-tracks,heldout-tracks --seeds 9400-9599``.
"""

from __future__ import annotations

import argparse
import json

from quad_dob_env.envs import QuadrotorVectorEnv
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluate import parse_seeds
from quad_dob_training.metrics import flight_metrics
from quad_dob_training.policies import fly_policy, make_policy

MARGIN = {"extra_latency": 0.01, "motor_time_constant_scale": 1.5}


def reference_kinds(scenario, seeds: list[int]) -> list[str]:
    """The kind of reference each seed's vehicle flies (the member drawn at its reset, the
    same whoever flies it), so that a flight lost mid-descent still counts as a landing."""
    env = QuadrotorVectorEnv(len(seeds), scenario)
    env.reset(seed=seeds)
    kinds = scenario.trajectory.kinds
    return [kinds[member] for member in env.core.reference_member]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policies", required=True,
                        help="comma-separated policy specs, the base first")
    parser.add_argument("--scenarios", default="random-tracks,heldout-tracks")
    parser.add_argument("--seeds", default="9400-9599")
    parser.add_argument("--json", help="write every number to this file")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    specs = args.policies.split(",")
    report: dict[str, dict[str, dict]] = {}
    print("| scenario | policy | flights | landings | lost | lost that the base kept | "
          "lost seeds (L: a landing) |")
    print("|---|---|---|---|---|---|---|")
    for name in args.scenarios.split(","):
        scenario = make_scenario(name, benchmark="v2", **MARGIN)
        kind_of = dict(zip(seeds, reference_kinds(scenario, seeds), strict=True))
        landings = sum(kind == "landing" for kind in kind_of.values())
        report[name] = {}
        base_lost: set[int] = set()
        for index, spec in enumerate(specs):
            flights = fly_policy(make_policy(spec), scenario, seeds)
            lost = [seed for seed, f in zip(seeds, flights, strict=True)
                    if flight_metrics(f)["crashed"]]
            if index == 0:
                base_lost = set(lost)
            beyond = [seed for seed in lost if seed not in base_lost]
            report[name][spec] = {"flights": len(flights), "landings": landings, "lost": lost,
                                  "lost_landings": [s for s in lost if kind_of[s] == "landing"],
                                  "lost_base_kept": beyond}
            shown = ", ".join(f"{seed}{' L' if kind_of[seed] == 'landing' else ''}"
                              for seed in lost)
            print(f"| {name} | {spec} | {len(flights)} | {landings} | {len(lost)} | "
                  f"{len(beyond) if index else '-'} | {shown or '-'} |", flush=True)
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"seeds": seeds, "scenario_options": MARGIN, "policies": specs,
                       "scenarios": report}, file, indent=1)


if __name__ == "__main__":
    main()
