"""A trained residual against its own base, in the loop it was trained in.

``quad-dob train``'s evaluation flies the id's named loop: a run whose ``env_kwargs`` change
the loop (``scenario_options`` such as ``estimator_wrench``, or ``base_benchmark``) is scored
there, not in its own. This script flies each run's policy and its base with the run's own
env options, scenario options, benchmark and base gains, on the same seeds, and prints the
RMS position error after the first fifth of each flight. Beside it, what the policy did
over the same steps: the share of its action components at their bounds (|a| >= 0.99),
the share of steps it flew below 0.9 of its authority (its gate, floor fade and supervisor
together, where the run has them), and its mean vertical correction Δa_z [m/s²]. A policy
pinned at its bounds and faded out by its supervisor scores near its base's error and has
learned nothing:

    python benchmarks/residual_in_its_loop.py RUN [RUN ...] --seeds 10000-10007

docs/residual-v4.md uses it to ask which of Benchmark v4's changes decides whether a
residual learns.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from quad_dob_composition import make_vector_env
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.policies import Policy, make_policy
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rl.vec_env import env_options
from quad_dob_training.rollout import warm_up_copy


@dataclass
class Flown:
    """One run's flights, after the first fifth of each: RMS ‖x - x_d‖ [m], the share of
    action components at their bounds, the share of steps flown below 0.9 of the
    residual's authority and the mean vertical correction Δa_z [m/s²]."""

    rms: float
    saturated: float
    faded: float
    vertical: float


def load(run: Path) -> Policy:
    """The run's policy."""
    return make_policy(f"residual:{run}", trust_pickle=True)


def fly(run: Path, scenario: str, seeds: list[int], with_policy: bool,
        warm_up: bool = False, policy: Policy | None = None) -> Flown:
    """The run's policy (or its base alone) on ``scenario`` in the run's own loop.
    ``warm_up``: the scenario's first few steps only (``rollout.warm_up_copy``), which
    compile its kernels on a first run. ``policy``: the run's, already loaded."""
    policy = load(run) if policy is None else policy
    config = yaml.safe_load((run / "config.yaml").read_text())
    options = env_options(config["env_kwargs"])
    options.pop("scenario", None)
    benchmark = options.pop("benchmark", None)
    flown = make_scenario(scenario, benchmark=benchmark,
                          **(options.pop("scenario_options", None) or {}))
    if warm_up:
        flown = warm_up_copy(flown)
    env = make_vector_env(len(seeds), flown, **options)
    observations, _ = env.reset(seed=seeds)
    errors, actions_flown, authorities = [], [], []
    for _ in range(flown.steps):
        actions = np.clip(policy.act(observations) if with_policy
                          else np.zeros((len(seeds), 4)), -1.0, 1.0)
        observations, *_ = env.step(actions)
        core = env.core
        errors.append(core.state.position - core.reference_table[core.reference_row, 0])
        actions_flown.append(actions)
        authorities.append(env.residual.authority.copy())
    first = flown.steps // 5
    settled = np.array(errors)[first:]
    actions_flown = np.array(actions_flown)[first:]
    scale = float(options.get("acceleration_scale", 0.0))  # Δa per unit action [m/s²]
    return Flown(rms=float(np.sqrt((settled ** 2).sum(axis=-1).mean())),
                 saturated=float((np.abs(actions_flown) >= 0.99).mean()),
                 faded=float((np.array(authorities)[first:] < 0.9).mean()),
                 vertical=scale * float(actions_flown[..., 2].mean()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="quad-dob train run folders")
    parser.add_argument("--scenario", default="random-tracks")
    parser.add_argument("--seeds", default="10000-10007")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    print(f"residual_in_its_loop: {len(args.runs)} runs x (policy, base) on {args.scenario} "
          f"x {len(seeds)} seeds", file=sys.stderr, flush=True)
    loaded = {}
    with Progress("loading runs", len(args.runs)) as progress:  # a load takes seconds
        for run in args.runs:
            progress.start(str(run))
            loaded[run] = load(run)
            progress.done()
    # a first run compiles each loop's kernels here, under a notice
    with compiling_notice():
        for run in args.runs:
            fly(run, args.scenario, seeds, True, warm_up=True, policy=loaded[run])
    print(f"{args.scenario}, seeds {args.seeds}, after the first fifth of each flight: RMS "
          "position [mm]; the policy's action components at their bounds, steps flown below "
          "0.9 of its authority, mean Δa_z [m/s²]")
    with Progress("residual_in_its_loop", 2 * len(args.runs)) as progress:
        for run in args.runs:
            progress.start(f"{run.name}, policy")
            policy = fly(run, args.scenario, seeds, True, policy=loaded[run])
            progress.done(f"{1000 * policy.rms:.1f} mm")
            progress.start(f"{run.name}, base")
            base = fly(run, args.scenario, seeds, False, policy=loaded[run])
            progress.done(f"{1000 * base.rms:.1f} mm")
            progress.print(f"{run.name:24} policy {1000 * policy.rms:6.1f}  base "
                           f"{1000 * base.rms:6.1f}  ({100 * (policy.rms / base.rms - 1):+.0f} "
                           f"%)  at bounds {100 * policy.saturated:.0f} %  faded "
                           f"{100 * policy.faded:.1f} %  Δa_z {policy.vertical:+.2f}")


if __name__ == "__main__":
    main()
