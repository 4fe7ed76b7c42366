"""Tracking error of every controller in the wind scenarios, over several seeds.

Run by hand: ``python benchmarks/wind_tracking.py [--seeds 10]``. Prints a markdown table of
the RMS position error after t = 2 s (mean ± std over the seeds that finished) and how many
flights lost the vehicle; the README quotes it.
"""

from __future__ import annotations

import argparse

import numpy as np

from baselines import make_controller
from quad_dob_env.scenarios import make_scenario
from training.metrics import flight_metrics
from training.rollout import fly

SCENARIOS = ("dryden-helix", "dryden-helix-gusts", "gusty-hover", "takeoff-landing-wind")
CONTROLLERS = ("geometric", "geometric-ndob", "geometric-ndob:tuned", "pid", "smc")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    scenarios = [make_scenario(name) for name in SCENARIOS]
    results = {(s, c): [] for s in SCENARIOS for c in CONTROLLERS}
    for controller in CONTROLLERS:
        for seed in range(args.seeds):
            for flight in fly(make_controller(controller), scenarios, seed=seed):
                results[flight.scenario, controller].append(
                    (flight_metrics(flight)["rms_position_settled"],
                     flight.termination_reason != "time_limit"))
    print(f"RMS position error after t = 2 s [m], mean ± std over seeds 0-{args.seeds - 1}; "
          "lost = flights that ended early\n")
    print("| controller | " + " | ".join(SCENARIOS) + " |")
    print("|---|" + "---|" * len(SCENARIOS))
    for controller in CONTROLLERS:
        cells = []
        for scenario in SCENARIOS:
            rows = results[scenario, controller]
            finished = np.array([rms for rms, lost in rows if not lost])
            lost = sum(lost for _, lost in rows)
            text = f"{finished.mean():.3f} ± {finished.std():.3f}" if len(finished) else "—"
            cells.append(text + (f" (lost {lost}/{len(rows)})" if lost else ""))
        print(f"| {controller} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
