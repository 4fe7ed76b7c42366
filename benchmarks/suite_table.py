"""The README's compact Benchmark v2 table from a ``quad-dob evaluate --suite
--delay-margins`` run: one row per scenario, one column per policy.

``python benchmarks/suite_table.py results/v2-suite [--skip NAME ...]`` prints, per cell,
the RMS position error after the scenario's settle time in mm with its 95 % bootstrap
interval, the delay margin, the flights lost of the seeds, and the distinct flights where
fewer than the seeds (a scenario whose seeds vary nothing flies one flight).
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--skip", nargs="*", default=[], help="policies to leave out")
    args = parser.parse_args()
    rows = [row for row in csv.DictReader(open(args.folder / "evaluation.csv"))
            if row["policy"] not in args.skip]
    policies = list(dict.fromkeys(row["policy"] for row in rows))
    scenarios = list(dict.fromkeys(row["scenario"] for row in rows))
    cell = {(row["scenario"], row["policy"]): row for row in rows}
    print("| scenario | " + " | ".join(policies) + " |")
    print("|---|" + "---|" * len(policies))
    for scenario in scenarios:
        cells = []
        for policy in policies:
            row = cell.get((scenario, policy))
            if row is None:
                cells.append("—")
                continue
            text = (f"{1000 * float(row['rms_position_settled_mean']):.1f} "
                    f"[{1000 * float(row['rms_position_settled_low']):.1f}, "
                    f"{1000 * float(row['rms_position_settled_high']):.1f}]")
            if row.get("delay_margin_text"):
                text += f", {row['delay_margin_text']}"
            if int(row["crashes"]):
                text += f", **{row['crashes']} lost**"
            if row.get("distinct_flights") and row["distinct_flights"] != row["flights"]:
                text += f", {row['distinct_flights']} distinct"
            cells.append(text)
        print(f"| {scenario} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
