"""How often the shipped residual's authority gate opens in calm air under each sensing.

The gate gives the residual authority only where the observer sees a force disturbance of
more than half the gate (``quad_dob_env.envs.residual``). Fed a noisy estimate, the
observer turns velocity noise into apparent force; this counts the steps (after 2 s) on
which the gate is open at all, on ``paper-none`` (no disturbance), seeds 9001-9020.

Run by hand: ``python benchmarks/gate_under_noise.py``; ``--policy residual:PATH --scenario
hover-calm --benchmark v2`` measures another residual in another calm scenario and loop.
"""

from __future__ import annotations

import argparse

import numpy as np

from quad_dob_composition import make_vector_env
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.policies import make_policy

SEEDS = list(range(9001, 9021))


def open_share(sensing: str, scenario: str = "paper-none", spec: str = "residual",
               benchmark: str = "v1") -> tuple[float, float]:
    """The share of steps after 2 s with the gate open, and the mean authority."""
    policy = make_policy(spec)
    flown = make_scenario(scenario, sensing=sensing, benchmark=benchmark)
    env = make_vector_env(len(SEEDS), flown, **policy.env_kwargs())
    obs, _ = env.reset(seed=SEEDS)
    residual = env.residual
    gate = residual.authority_gate
    opened, authorities = [], []
    for step in range(flown.steps):
        seen = np.linalg.norm(residual.extra_observation[:, 4:7], axis=1)
        authority = np.clip(2.0 * seen / gate - 1.0, 0.0, 1.0)
        if step * flown.dt >= 2.0:
            opened.append(authority > 0)
            authorities.append(authority)
        obs, *_ = env.step(policy.act(obs))
    return float(np.mean(opened)), float(np.mean(authorities))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default="residual", help="a residual policy spec")
    parser.add_argument("--scenario", default="paper-none", help="a calm scenario")
    parser.add_argument("--benchmark", default="v1", choices=("v1", "v2"))
    args = parser.parse_args()
    print("| sensing | gate open, share of steps after 2 s | mean authority |")
    print("|---|---|---|")
    for sensing in ("ideal", "mocap", "gnss-imu"):
        share, authority = open_share(sensing, args.scenario, args.policy, args.benchmark)
        print(f"| {sensing} | {share:.1%} | {authority:.3f} |")


if __name__ == "__main__":
    main()
