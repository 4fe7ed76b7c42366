"""The sensing table of docs/benchmark-v2-sensing.md from three ``quad-dob evaluate`` runs
(one per sensing preset).

Run by hand after the evaluations that page names::

    for s in ideal mocap gnss-imu; do quad-dob evaluate --policies ... --scenarios ... \\
        --seeds 9001-9020 --scenario-option sensing=$s --delay-margins \\
        --out results/sensing/$s; done
    python benchmarks/sensing_table.py results/sensing

Prints, per scenario, each policy's RMS position error (t >= 2 s) with its 95 % bootstrap
interval, flights lost and delay margin under each preset; then the estimator's RMS errors.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

PRESETS = ("ideal", "mocap", "gnss-imu")


def _rows(folder: Path) -> dict[str, list[dict]]:
    return {preset: list(csv.DictReader(open(folder / preset / "evaluation.csv")))
            for preset in PRESETS}


def _margin(text: str) -> str:
    return text.replace("none (loses flights at 0 ms)", "none")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    folder = parser.parse_args().folder
    rows = _rows(folder)
    scenarios = list(dict.fromkeys(row["scenario"] for row in rows["ideal"]))
    for scenario in scenarios:
        print(f"**{scenario}**: RMS ‖e_x‖ after 2 s [m], mean [95 % CI]; flights lost of "
              "20; delay margin\n")
        print("| policy | " + " | ".join(PRESETS) + " |")
        print("|---|" + "---|" * len(PRESETS))
        policies = [row["policy"] for row in rows["ideal"] if row["scenario"] == scenario]
        for policy in policies:
            cells = []
            for preset in PRESETS:
                row = next(r for r in rows[preset]
                           if r["scenario"] == scenario and r["policy"] == policy)
                lost = int(row["crashes"])
                cells.append(f"{float(row['rms_position_settled_mean']):.4f} "
                             f"[{float(row['rms_position_settled_low']):.4f}, "
                             f"{float(row['rms_position_settled_high']):.4f}]"
                             + (f", **{lost} lost**" if lost else "")
                             + f"; {_margin(row.get('delay_margin_text', ''))}")
            print(f"| {policy} | " + " | ".join(cells) + " |")
        print()
    print("Estimator RMS error after 2 s (mean over every policy's flights): position [mm], "
          "velocity [mm/s], attitude [mrad]\n")
    print("| scenario | " + " | ".join(PRESETS[1:]) + " |")
    print("|---|" + "---|" * (len(PRESETS) - 1))
    for scenario in scenarios:
        cells = []
        for preset in PRESETS[1:]:
            mine = [r for r in rows[preset] if r["scenario"] == scenario]
            means = [sum(float(r[f"rms_estimate_{key}_settled_mean"]) for r in mine) / len(mine)
                     for key in ("position", "velocity", "attitude")]
            cells.append(f"{1000 * means[0]:.2f} mm, {1000 * means[1]:.1f} mm/s, "
                         f"{1000 * means[2]:.2f} mrad")
        print(f"| {scenario} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
