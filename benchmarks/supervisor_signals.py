"""The residual supervisor's signals in flight: where to put its limits, and how often they fade.

Flies a residual policy (``--policy residual:PATH``; without one, its base alone: the
residual options of ``--options`` with a zero residual) on each scenario of the benchmark,
nominal and under the margin (``benchmark_v3.TUNING_MARGIN``), and prints per scenario the
99th and 99.9th percentiles and the maximum of the three signals the supervisor reads
(``quad_dob_env.residual.supervisor``: body rate, attitude error to the base's command,
the residual's share of the command) over every step flown, and, with the policy's own
supervisor, the share of steps on which it faded the residual below 0.9.

The supervisor's limits are chosen from these figures on tuning seeds (100-119): each one a
clear factor above what nominal flight reaches, so that nominal flight keeps its residual,
and below what the flights lost under the margin reach before they are lost.

    python benchmarks/supervisor_signals.py --seeds 100-119
    python benchmarks/supervisor_signals.py --policy residual:runs/X --seeds 100-119
    python benchmarks/supervisor_signals.py \
        --limits body_rate=7,attitude_error=2.2,residual_share=0.45
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from quad_dob_composition import make_vector_env
from quad_dob_env.benchmark_v3 import TUNING_MARGIN
from quad_dob_env.residual.supervisor import SIGNALS
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.console import text_table
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.policies import make_policy
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rollout import warm_up_copy

SCENARIOS = ("hover-calm", "gusty-hover", "dryden-helix", "dryden-helix-gusts",
             "takeoff-landing-wind", "ground-effect-landing", "random-tracks",
             "figure8-wind-0", "figure8-wind-8.5", "figure8-wind-12.1")
# limits no flight reaches: the supervisor reads its signals and never trips
WATCH_ONLY = {"body_rate": 1e9, "attitude_error": 1e9, "residual_share": 1e9}


def fly(scenario: str, benchmark: str, seeds: list[int], model, env_kwargs: dict,
        loop: dict, warm_up: bool = False) -> dict:
    """Every step's signals (steps, 3), the supervisor's factors, and the flights lost, for
    ``model`` (a ``Policy`` with a model; None: a zero residual) in an env of ``env_kwargs``.
    ``warm_up``: the scenario's first few steps only (``rollout.warm_up_copy``), which
    compile its kernels on a first run."""
    flown = make_scenario(scenario, benchmark=benchmark, **loop)
    if warm_up:
        flown = warm_up_copy(flown)
    kwargs = dict(env_kwargs)
    own = kwargs.get("supervisor")
    kwargs["supervisor"] = own if own is not None else WATCH_ONLY
    env = make_vector_env(len(seeds), flown, **kwargs)
    obs, _ = env.reset(seed=seeds)
    alive = np.ones(len(seeds), bool)
    lost = np.zeros(len(seeds), bool)
    signals, factors = [], []
    limits = env.residual.supervisor.limits
    scale = np.array([getattr(limits, name) for name in SIGNALS])
    for _ in range(flown.steps):
        actions = np.zeros((len(seeds), 4)) if model is None else model.act(obs)
        obs, _, terminated, truncated, _ = env.step(actions)
        supervisor = env.residual.supervisor
        signals.append((supervisor.ratios * scale)[alive])
        factors.append(supervisor.factor[alive].copy())
        lost |= alive & terminated
        alive &= ~(terminated | truncated)
        if not alive.any():
            break
    return {"signals": np.concatenate(signals), "factors": np.concatenate(factors),
            "lost": int(lost.sum()), "own": own is not None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default=None,
                        help="residual:PATH (default: the base alone, zero residual)")
    parser.add_argument("--base", default="geometric-ndob:tuned")
    parser.add_argument("--benchmark", default="v4")
    parser.add_argument("--seeds", default="100-119")
    parser.add_argument("--scenarios", default=",".join(SCENARIOS))
    parser.add_argument("--limits", default=None,
                        help="body_rate=R,attitude_error=A,residual_share=S: fly the base "
                             "alone under a supervisor with these limits (its fading "
                             "counted)")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    scenarios = args.scenarios.split(",")
    loops = (("nominal", {}), ("margin", dict(TUNING_MARGIN)))
    print(f"supervisor_signals: {args.policy or args.base + ' alone'} on {len(scenarios)} "
          f"scenarios x (nominal, margin) x {len(seeds)} seeds, Benchmark {args.benchmark}",
          file=sys.stderr, flush=True)
    if args.policy is None:  # the base alone: a zero residual in the acceleration mode
        model = None
        options = {"base_controller": args.base, "residual_mode": "acceleration"}
        if args.limits:
            options["supervisor"] = {key: float(value) for key, value in
                                     (item.split("=") for item in args.limits.split(","))}
    else:
        model = make_policy(args.policy, trust_pickle=True)
        options = model.env_kwargs()
    # a first run compiles each loop's kernels here, under a notice
    with compiling_notice():
        for _, loop in loops:
            fly(scenarios[0], args.benchmark, seeds, model, options, loop, warm_up=True)
    rows = []
    with Progress("supervisor_signals", len(scenarios) * len(loops)) as progress:
        for scenario in scenarios:
            for label, loop in loops:
                progress.start(f"{scenario}, {label}")
                result = fly(scenario, args.benchmark, seeds, model, options, loop)
                progress.done(f"{result['lost']} lost")
                cells = []
                for k in range(len(SIGNALS)):
                    values = result["signals"][:, k]
                    p99, p999 = np.percentile(values, [99.0, 99.9])
                    cells.append(f"{p99:.3f}/{p999:.3f}/{values.max():.3f}")
                faded = (f"{100 * np.mean(result['factors'] < 0.9):.2f} %" if result["own"]
                         else "-")
                rows.append([scenario, label, str(result["lost"]), *cells, faded])
    # a table as wide as its cells (120 columns at most): printed once every row is flown
    print(f"policy {args.policy or args.base + ' alone'}, benchmark {args.benchmark}, seeds "
          f"{args.seeds}; per signal: p99 / p99.9 / max over every step flown\n")
    print(text_table(["scenario", "loop", "lost",
                      *(f"{name} p99/p99.9/max" for name in SIGNALS), "faded < 0.9"],
                     rows))


if __name__ == "__main__":
    main()
