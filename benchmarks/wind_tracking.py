"""Benchmark v1: every controller in every scenario with physical rotors, on held-out seeds.

Run by hand: ``python benchmarks/wind_tracking.py [--seeds 9001-9020]``. Prints a markdown
table, per scenario and controller, of the RMS position, tilt and heading errors after
t = 2 s (mean over the seeds; a lost flight counts over the part it flew), the flights
lost, and the position error's paired difference to the recommended geometric + NDOB with
its 95 % bootstrap interval; docs/benchmark-v1.md quotes it. The gains were tuned on seeds 100-109
(``quad-dob tune``); the default seeds here were never used for tuning.
"""

from __future__ import annotations

import argparse
import sys

from quad_dob_env import DEFAULT_BASE_CONTROLLER
from quad_dob_training.evaluation.evaluate import evaluate, parse_seeds

SCENARIOS = ("hover-calm", "hover-step-force", "ground-effect-landing", "gusty-hover",
             "takeoff-landing-wind", "dryden-helix", "dryden-helix-gusts")
CONTROLLERS = ("geometric-ndob:tuned", "geometric-ndob", "geometric", "pid", "smc")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", default="9001-9020")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    print(f"wind_tracking: {len(CONTROLLERS)} controllers x {len(SCENARIOS)} scenarios x "
          f"{len(seeds)} seeds, Benchmark v1", file=sys.stderr, flush=True)
    rows = evaluate(list(CONTROLLERS), list(SCENARIOS), seeds, baseline=DEFAULT_BASE_CONTROLLER,
                    progress=True)
    print(f"Seeds {args.seeds}; after t = 2 s; Δ: paired difference of the RMS position error "
          f"to {DEFAULT_BASE_CONTROLLER} [m], mean [95 % CI]\n")
    print("| scenario | controller | RMS ‖e_x‖ [m] | RMS tilt [rad] | RMS heading [rad] | lost | "
          "Δ RMS ‖e_x‖ [m] |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        difference = ("—" if row["policy"] == DEFAULT_BASE_CONTROLLER else
                      f"{row['rms_position_settled_diff_mean']:+.4f} "
                      f"[{row['rms_position_settled_diff_low']:+.4f}, "
                      f"{row['rms_position_settled_diff_high']:+.4f}]")
        print(f"| {row['scenario']} | {row['policy']} | {row['rms_position_settled_mean']:.4f} | "
              f"{row['rms_tilt_settled_mean']:.3f} | {row['rms_heading_settled_mean']:.3f} | "
              f"{row['crashes']}/{row['flights']} | {difference} |")


if __name__ == "__main__":
    main()
