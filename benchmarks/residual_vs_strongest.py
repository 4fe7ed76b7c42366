"""Residual policies against the strongest classical baseline of each scenario (issue 29).

Flies every classical name the benchmark compares (``evaluation.ranking.candidates``) and
each residual given on the same seeds, takes the strongest per scenario by the one rule
(``evaluation.ranking``: fewest lost flights, then lowest mean RMS position error after the
settle time), and prints, per scenario: the strongest, each
residual's change against it with the 95 % bootstrap interval of the paired per-seed
difference, their mean and spread over the residuals (training seeds), the lost flights (and
of each residual's, those its base keeps), and the RMS rotor-command rate against the
residual's base, and each residual's change against its base (paired, mean over the
residuals with their range); ``--before SPEC`` adds one more policy's column (the v1 policy,
``residual:v1``). ``--scenario-option`` flies every scenario with that option (the margin
check: ``extra_latency=0.01 motor_time_constant_scale=1.5``). ``--loop KEY=VALUE`` sets one
of v3's loop quantities as ``loop_randomization`` names them (``thrust_model_factor``,
``hover_throttle=[a,b]``, ``hover_throttle_drift=[a,b]``, ``accelerometer_vibration``) on
``--vehicle``'s v3 loop (v4's with ``--scenario-option benchmark=v4``), as training draws
them (``loop_scenario_options``): issue 42's held-out world. ``--json FILE`` keeps every
number; ``--trust-pickle`` lets ``residual:PATH`` load your own runs.

Run by hand, e.g. ``python benchmarks/residual_vs_strongest.py --residuals
residual:runs/a,residual:runs/b --seeds 9201-9220 --suite``.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from quad_dob_training.cli.checks import key_values
from quad_dob_training.evaluation.evaluate import SUITES, evaluate, parse_seeds
from quad_dob_training.evaluation.ranking import Standing, candidates, strongest
from quad_dob_training.evaluation.statistics import bootstrap_mean, paired_difference
from quad_dob_training.policies import make_policy
from quad_dob_training.progress import Progress
from quad_dob_training.rl.vec_env import loop_scenario_options


def scores(metrics: list[dict]) -> dict[str, np.ndarray]:
    """The per-seed numbers this table compares: RMS position error after the settle time,
    lost flights and RMS rotor-command rate."""
    rate = [m["rms_command_rate"] for m in metrics]
    return {"rms": np.array([m["rms_position_settled"] for m in metrics]),
            "lost": np.array([bool(m["crashed"]) for m in metrics]),
            "rate": np.array([np.nan if r is None else r for r in rate], dtype=float)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--residuals", required=True, help="comma-separated residual specs")
    parser.add_argument("--scenarios", default="", help="comma-separated scenario names")
    parser.add_argument("--suite", action="store_true",
                        help="the whole suite of the benchmark flown (v2's by default)")
    parser.add_argument("--seeds", default="9201-9220")
    parser.add_argument("--scenario-option", action="append", default=[])
    parser.add_argument("--loop", action="append", default=[],
                        help="a v3 loop quantity as loop_randomization names it, KEY=VALUE")
    parser.add_argument("--vehicle", default="paper",
                        help="the vehicle whose v3 loop --loop changes (default: %(default)s)")
    parser.add_argument("--before", help="one more policy, reported in its own column")
    parser.add_argument("--json", help="write every number to this file")
    parser.add_argument("--trust-pickle", action="store_true",
                        help="unpickle residual:PATH zips (your own runs' folders)")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    # Benchmark v2's loop, as quad-dob evaluate flies by default
    options = {"benchmark": "v2", **key_values(args.scenario_option, "--scenario-option")}
    if args.loop:
        options.update(loop_scenario_options(key_values(args.loop, "--loop"), args.vehicle,
                                             str(options["benchmark"])))
    scenario_names = ([name for family in SUITES[options["benchmark"]].values()
                       for name in family]
                      if args.suite else args.scenarios.split(","))
    residual_specs = args.residuals.split(",")
    before = [args.before] if args.before else []
    classical = candidates(str(options["benchmark"]))
    specs = list(dict.fromkeys((*classical, *residual_specs, *before)))
    print(f"residual_vs_strongest: {len(specs)} policies ({len(classical)} classical, "
          f"{len(residual_specs) + len(before)} learned) x {len(scenario_names)} scenarios x "
          f"{len(seeds)} seeds, Benchmark {options['benchmark']}", file=sys.stderr, flush=True)
    with Progress("loading", 1) as progress:  # a residual's load takes seconds
        progress.start(f"{residual_specs[0]}, to find its base")
        base_spec = make_policy(residual_specs[0], benchmark=str(options["benchmark"]),
                                trust_pickle=args.trust_pickle).base
        progress.done(base_spec)
    report = {}
    print("| scenario | strongest baseline (mm) | residual (mm), mean of seeds [min, max] | "
          "change vs strongest, mean [min, max] | seeds whose paired 95 % CI < 0 "
          "(each residual's paired difference [95 % CI], mm) | "
          "lost: strongest / base / residuals (of them, kept by the base) | "
          "command rate: residual / base | change vs its base, mean [min, max] "
          "(seeds whose paired 95 % CI < 0) |"
          + (f" {args.before}: mm, vs strongest, lost, command rate |" if before else ""))
    print("|---|---|---|---|---|---|---|---|" + ("---|" if before else ""))
    per_seed: dict[tuple[str, str], list[dict]] = {}
    for number, name in enumerate(scenario_names, 1):
        # one scenario at a time, so each row prints as soon as it is flown; the evaluation
        # reports each policy it flies
        print(f"residual_vs_strongest: scenario {number}/{len(scenario_names)} {name}",
              file=sys.stderr, flush=True)
        evaluate(specs, [name], seeds, baseline=None, scenario_options=options,
                 per_seed=per_seed, trust_pickle=args.trust_pickle, progress=True)
        flown = {spec: scores(per_seed.pop((name, spec))) for spec in specs}
        best = strongest({spec: Standing(int(flown[spec]["lost"].sum()),
                                         float(flown[spec]["rms"].mean()))
                          for spec in classical}, classical)
        bar = flown[best]
        base = flown[base_spec]
        rows = []
        for spec in residual_specs:
            mine = flown[spec]
            difference = paired_difference(mine["rms"], bar["rms"])
            against_base = paired_difference(mine["rms"], base["rms"])
            rows.append({"spec": spec, "rms": bootstrap_mean(mine["rms"])._asdict(),
                         "change": difference.mean / bar["rms"].mean(),
                         "paired": difference._asdict(), "lost": int(mine["lost"].sum()),
                         "change_vs_base": against_base.mean / base["rms"].mean(),
                         "paired_vs_base": against_base._asdict(),
                         # issue 29's margin target: no flight lost that the base keeps
                         "lost_base_kept": int((mine["lost"] & ~base["lost"]).sum()),
                         "rate": float(np.nanmean(mine["rate"]))})
        report[name] = {"strongest": best, "strongest_rms": bootstrap_mean(
            bar["rms"])._asdict(), "strongest_lost": int(bar["lost"].sum()),
            "base_lost": int(base["lost"].sum()), "base_rate": float(np.nanmean(base["rate"])),
            "baselines": {spec: float(flown[spec]["rms"].mean()) for spec in classical},
            "residuals": rows}
        extra = ""
        if before:
            then = flown[args.before]
            report[name]["before"] = {
                "spec": args.before, "rms": bootstrap_mean(then["rms"])._asdict(),
                "paired": paired_difference(then["rms"], bar["rms"])._asdict(),
                "lost": int(then["lost"].sum()), "rate": float(np.nanmean(then["rate"]))}
            extra = (f" {1e3 * then['rms'].mean():.1f}, "
                     f"{100 * (then['rms'].mean() / bar['rms'].mean() - 1):+.0f} %, "
                     f"{int(then['lost'].sum())} lost, {np.nanmean(then['rate']):.0f} N/s |")
        means = [1e3 * row["rms"]["mean"] for row in rows]
        changes = [100 * row["change"] for row in rows]
        below = sum(row["paired"]["high"] < 0 for row in rows)
        rates = [row["rate"] for row in rows]
        vs_base = [100 * row["change_vs_base"] for row in rows]
        below_base = sum(row["paired_vs_base"]["high"] < 0 for row in rows)
        strong = report[name]["strongest_rms"]
        print(f"| {name} | {best} {1e3 * strong['mean']:.1f} "
              f"[{1e3 * strong['low']:.1f}, {1e3 * strong['high']:.1f}] | "
              f"{np.mean(means):.1f} [{min(means):.1f}, {max(means):.1f}] | "
              f"{np.mean(changes):+.0f} % [{min(changes):+.0f}, {max(changes):+.0f}] | "
              f"{below}/{len(rows)} ("
              + ", ".join(f"{1e3 * row['paired']['mean']:+.1f} [{1e3 * row['paired']['low']:+.1f}, "
                          f"{1e3 * row['paired']['high']:+.1f}]" for row in rows)
              + f") | {report[name]['strongest_lost']} / "
              f"{report[name]['base_lost']} / {', '.join(str(row['lost']) for row in rows)} "
              f"({', '.join(str(row['lost_base_kept']) for row in rows)}) | "
              f"{np.mean(rates):.0f} / {report[name]['base_rate']:.0f} "
              f"({np.mean(rates) / report[name]['base_rate']:.2f}x, max "
              f"{max(rates) / report[name]['base_rate']:.2f}x) | "
              f"{np.mean(vs_base):+.0f} % [{min(vs_base):+.0f}, {max(vs_base):+.0f}] "
              f"({below_base}/{len(rows)}) |" + extra, flush=True)
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"seeds": seeds, "scenario_options": {
                key: value if isinstance(value, (str, int, float, bool, type(None))) else
                repr(value) for key, value in options.items()}, "scenarios": report}, file,
                indent=1)


if __name__ == "__main__":
    main()
