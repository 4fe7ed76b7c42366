"""A trained residual against its own base, in the loop it was trained in.

``quad-dob train``'s evaluation flies the id's named loop: a run whose ``env_kwargs`` change
the loop (``scenario_options`` such as ``estimator_wrench``, or ``base_benchmark``) is scored
there, not in its own. This script flies each run's policy and its base with the run's own
env options, scenario options, benchmark and base gains, on the same seeds, and prints the
RMS position error after the first fifth of each flight:

    python benchmarks/residual_in_its_loop.py RUN [RUN ...] --seeds 10000-10007

docs/residual-v4.md uses it to ask which of Benchmark v4's changes decides whether a
residual learns.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from quad_dob_composition import make_vector_env
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.policies import make_policy
from quad_dob_training.rl.vec_env import env_options


def settled_rms(run: Path, scenario: str, seeds: list[int], with_policy: bool) -> float:
    """RMS ‖x - x_d‖ [m] after the first fifth of each flight, all seeds together."""
    policy = make_policy(f"residual:{run}", trust_pickle=True)
    config = yaml.safe_load((run / "config.yaml").read_text())
    options = env_options(config["env_kwargs"])
    options.pop("scenario", None)
    benchmark = options.pop("benchmark", None)
    flown = make_scenario(scenario, benchmark=benchmark,
                          **(options.pop("scenario_options", None) or {}))
    env = make_vector_env(len(seeds), flown, **options)
    observations, _ = env.reset(seed=seeds)
    errors = []
    for _ in range(flown.steps):
        actions = (policy.act(observations) if with_policy
                   else np.zeros((len(seeds), 4)))
        observations, *_ = env.step(actions)
        core = env.core
        errors.append(core.state.position - core.reference_table[core.reference_row, 0])
    settled = np.array(errors)[flown.steps // 5:]
    return float(np.sqrt((settled ** 2).sum(axis=-1).mean()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="quad-dob train run folders")
    parser.add_argument("--scenario", default="random-tracks")
    parser.add_argument("--seeds", default="10000-10007")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    print(f"{args.scenario}, seeds {args.seeds}, RMS position after the first fifth [mm]")
    for run in args.runs:
        policy = 1000 * settled_rms(run, args.scenario, seeds, True)
        base = 1000 * settled_rms(run, args.scenario, seeds, False)
        print(f"{run.name:24} policy {policy:6.1f}  base {base:6.1f}  "
              f"({100 * (policy / base - 1):+.0f} %)", flush=True)


if __name__ == "__main__":
    main()
