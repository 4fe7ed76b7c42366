"""``quad-dob evaluate``: every policy on every scenario over the given seeds.

Scores (``training.metrics``, the code ``quad-dob paper`` uses): RMS position error and RMS
attitude error after t = 2 s, control effort (RMS applied moment norm), crash rate. Writes
``evaluation.md``, ``evaluation.csv``, ``evaluation.png`` (bars with ±std) and the
interactive ``report.html`` (figures of the first seed), or prints the rows as JSON with
``scenario`` and ``policy`` keys.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from quad_dob_env.scenarios import make_scenario
from training.metrics import flight_metrics
from training.policies import fly_policy, make_policy
from training.report import write_report

SCORES = (("rms_position_settled", "RMS ‖e_x‖, t≥2 s [m]"),
          ("rms_attitude_settled", "RMS attitude, t≥2 s [rad]"),
          ("rms_moment", "effort: RMS ‖M‖ [N m]"))


def parse_seeds(text: str) -> list[int]:
    """``"20"`` -> seeds 0-19; ``"9001-9020"`` -> those 20 seeds (inclusive)."""
    text = str(text).strip()
    try:
        if "-" in text:
            first, last = (int(part) for part in text.split("-", 1))
            if last < first:
                raise ValueError
            return list(range(first, last + 1))
        count = int(text)
        if count < 1:
            raise ValueError
        return list(range(count))
    except ValueError:
        raise ValueError(f"seeds must be a count >= 1 such as 20 or an inclusive range A-B "
                         f"such as 9001-9020, got {text!r}") from None


def evaluate(policies: list[str], scenarios: list[str], seeds: list[int],
             first_flights: dict | None = None) -> list[dict]:
    """One row per (scenario, policy): mean and std over seeds of each score, crash rate.
    ``first_flights``, when given, collects each scenario's flights on the first seed."""
    built = [make_policy(spec) for spec in policies]
    rows = []
    for scenario_name in scenarios:
        scenario = make_scenario(scenario_name)
        for policy in built:
            flights = fly_policy(policy, scenario, seeds)
            if first_flights is not None:
                first_flights.setdefault(scenario_name, []).append(flights[0])
            metrics = [flight_metrics(f) for f in flights]
            row: dict = {"scenario": scenario_name, "policy": policy.name,
                         "seeds": f"{seeds[0]}-{seeds[-1]}" if len(seeds) > 1 else str(seeds[0])}
            for key, _ in SCORES:
                values = np.array([m[key] for m in metrics], dtype=float)
                row[f"{key}_mean"] = float(values.mean())
                row[f"{key}_std"] = float(values.std())
            row["crash_rate"] = float(np.mean([m["crashed"] for m in metrics]))
            rows.append(row)
    return rows


def write_tables(rows: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "evaluation.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    (out / "evaluation.md").write_text(markdown_table(rows) + "\n")
    _bar_plot(rows, out / "evaluation.png")


def markdown_table(rows: list[dict]) -> str:
    header = ["scenario", "policy", *(label for _, label in SCORES), "crash rate"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        scores = [f"{row[f'{key}_mean']:.4f} ± {row[f'{key}_std']:.4f}" for key, _ in SCORES]
        lines.append(f"| {row['scenario']} | {row['policy']} | " + " | ".join(scores)
                     + f" | {row['crash_rate']:.0%} |")
    return "\n".join(lines)


def _bar_plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenarios = list(dict.fromkeys(row["scenario"] for row in rows))
    policies = list(dict.fromkeys(row["policy"] for row in rows))
    figure, axis = plt.subplots(figsize=(1.6 + 1.4 * len(scenarios) * len(policies) / 2, 3.6))
    width = 0.8 / len(policies)
    for j, policy in enumerate(policies):
        mine = {row["scenario"]: row for row in rows if row["policy"] == policy}
        x = np.arange(len(scenarios)) + (j - (len(policies) - 1) / 2) * width
        axis.bar(x, [mine[s]["rms_position_settled_mean"] for s in scenarios], width,
                 yerr=[mine[s]["rms_position_settled_std"] for s in scenarios], capsize=3,
                 label=policy)
    axis.set_xticks(np.arange(len(scenarios)), scenarios)
    axis.set_ylabel("RMS position error, t ≥ 2 s [m]")
    axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def main(policies: list[str], scenarios: list[str], seeds: str, out: Path,
         as_json: bool) -> int:
    seed_list = parse_seeds(seeds)
    first_flights: dict = {}
    rows = evaluate(policies, scenarios, seed_list, first_flights)
    if as_json:
        print(json.dumps(rows, indent=1))
        return 0
    write_tables(rows, out)
    columns = [("scenario", "scenario"), ("policy", "policy"), ("seeds", "seeds")]
    for key, label in SCORES:
        columns += [(f"{key}_mean", f"{label} mean"), (f"{key}_std", "± std")]
    write_report(out / "report.html", f"quad-dob evaluate (figures: seed {seed_list[0]})",
                 rows, [*columns, ("crash_rate", "crash rate")], first_flights)
    print(markdown_table(rows))
    print(f"\nwrote {out / 'evaluation.md'}, evaluation.csv, evaluation.png, report.html")
    return 0
