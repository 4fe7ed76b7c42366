"""The compact benchmark table of docs/benchmark-v2.md (and of v3's and v4's pages) from a
``quad-dob evaluate --suite --delay-margins`` run: one row per scenario, one column per policy.

``python benchmarks/suite_table.py results/v2-suite [--skip NAME ...]`` prints, per cell,
the RMS position error after the scenario's settle time in mm with its 95 % bootstrap
interval, the delay margin, the flights lost of the seeds, and the distinct flights where
fewer than the seeds (a scenario whose seeds vary nothing flies one flight).

Several folders make one table, a row per benchmark, vehicle and scenario (RAPTOR's in
docs/raptor.md: ``python benchmarks/suite_table.py DIR1 DIR2 ... --rank raptor``), where
each benchmark's own shipped policy (``residual:v1`` in v1, ...) is one column, ``residual``.
``--rank NAME`` adds NAME's place among the row's policies by the one rule below.

``--strongest`` prints instead, per scenario, the strongest classical row by the one rule
(``evaluation.ranking``: fewest flights lost, then the lowest mean RMS error; what a learned
policy has to beat) and the runner-up, and whether the two are
told apart: by the paired interval of their difference where one of them is the run's
``--baseline`` (the CSV holds only those), else by whether their 95 % intervals overlap.
Learned policies (``residual``, ``ppo:``, ``sac:``) are left out.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

from quad_dob_training.evaluation.ranking import Standing, ranked


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", type=Path, nargs="+", metavar="folder")
    parser.add_argument("--skip", nargs="*", default=[], help="policies to leave out")
    parser.add_argument("--strongest", action="store_true",
                        help="the strongest classical baseline per scenario instead")
    parser.add_argument("--rank", metavar="NAME",
                        help="add NAME's place among each row's policies (the one rule)")
    args = parser.parse_args()
    rows = [row for folder in args.folders
            for row in csv.DictReader(open(folder / "evaluation.csv"))
            if row["policy"] not in args.skip]
    if args.strongest:
        strongest(rows)
        return
    several = len(args.folders) > 1
    if several:  # one column for each benchmark's own shipped residual, as bare residual
        for row in rows:
            if row["policy"] == f"residual:{row.get('benchmark')}":
                row["policy"] = "residual"
    policies = list(dict.fromkeys(row["policy"] for row in rows))
    if args.rank is not None and args.rank not in policies:
        parser.error(f"--rank {args.rank}: no such policy in the rows; they are "
                     + ", ".join(policies))
    # a row of the table: (benchmark, vehicle, scenario); one folder's rows are its scenarios
    keys = list(dict.fromkeys(_row_key(row) for row in rows))
    cell = {(_row_key(row), row["policy"]): row for row in rows}
    paths = {row["delay_margin_path"] for row in rows if row.get("delay_margin_path")}
    if paths:  # one line for where the margins' latency went, not a word in every cell
        print(f"Delay margins: latency added on the {', '.join(sorted(paths))}\n")
    head = ["benchmark", "vehicle", "scenario"] if several else ["scenario"]
    if args.rank is not None:
        head.append(f"{args.rank}'s rank")
    print("| " + " | ".join(head + policies) + " |")
    print("|---|" + "---|" * (len(head) - 1 + len(policies)))
    for key in keys:
        cells = list(key) if several else [key[2]]
        if args.rank is not None:
            flown = {policy: Standing(int(row["crashes"]), float(row["rms_position_settled_mean"]))
                     for (where, policy), row in cell.items() if where == key}
            order = ranked(flown)
            cells.append(f"{order.index(args.rank) + 1} of {len(order)}"
                         if args.rank in order else "—")
        for policy in policies:
            row = cell.get((key, policy))
            if row is None:
                cells.append("—")
                continue
            text = (f"{1000 * float(row['rms_position_settled_mean']):.1f} "
                    f"[{1000 * float(row['rms_position_settled_low']):.1f}, "
                    f"{1000 * float(row['rms_position_settled_high']):.1f}]")
            if row.get("delay_margin_text"):
                margin = row["delay_margin_text"]
                path = row.get("delay_margin_path")
                text += ", " + (margin.removesuffix(f" ({path})") if path else margin)
            if int(row["crashes"]):
                text += f", **{row['crashes']} lost**"
            if row.get("distinct_flights") and row["distinct_flights"] != row["flights"]:
                text += f", {row['distinct_flights']} distinct"
            cells.append(text)
        print("| " + " | ".join(cells) + " |")


def _row_key(row: dict) -> tuple[str, str, str]:
    return row.get("benchmark", ""), row.get("vehicle", ""), row["scenario"]


LEARNED = ("residual", "ppo:", "sac:")


def _interval(row: dict) -> str:
    return (f"{1000 * float(row['rms_position_settled_mean']):.1f} "
            f"[{1000 * float(row['rms_position_settled_low']):.1f}, "
            f"{1000 * float(row['rms_position_settled_high']):.1f}]")


def strongest(rows: list[dict]) -> None:
    """Per scenario: the strongest classical row flown and the runner-up
    (``evaluation.ranking``), and whether they are told apart (module docstring)."""
    print("| scenario | strongest classical baseline [mm] | runner-up [mm] | told apart by |")
    print("|---|---|---|---|")
    for scenario in dict.fromkeys(row["scenario"] for row in rows):
        flown = {row["policy"]: row for row in rows if row["scenario"] == scenario
                 and not row["policy"].startswith(LEARNED)}
        order = ranked({policy: Standing(int(row["crashes"]),
                                         float(row["rms_position_settled_mean"]))
                        for policy, row in flown.items()})
        best, second = flown[order[0]], flown[order[1]]
        paired = next((row for row in (second, best) if row.get("baseline")
                       and row["baseline"] in (best["policy"], second["policy"])
                       and row["baseline"] != row["policy"]
                       and row.get("rms_position_settled_diff_low")), None)
        if paired is not None:
            low = 1000 * float(paired["rms_position_settled_diff_low"])
            high = 1000 * float(paired["rms_position_settled_diff_high"])
            verdict = (f"paired difference [{low:.1f}, {high:.1f}] mm: "
                       + ("excludes zero" if low > 0 or high < 0 else "includes zero"))
        else:
            apart = (float(best["rms_position_settled_high"])
                     < float(second["rms_position_settled_low"]))
            verdict = "intervals " + ("apart" if apart else "overlap")
        print(f"| {scenario} | `{best['policy']}` {_interval(best)} | "
              f"`{second['policy']}` {_interval(second)} | {verdict} |")


if __name__ == "__main__":
    main()
