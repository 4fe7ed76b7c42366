"""``quad-dob paper``: the paper's scenarios with every controller, as tables and figures.

Scenarios paper-none, paper-I, paper-II, paper-IIA and ground-effect-landing; controllers
geometric, geometric-ndob (the paper's observer gains), geometric-ndob:tuned, pid, smc.
Writes ``table.md``, ``table.csv`` and (unless ``figures=False``) six PNGs per scenario and
the interactive ``report.html``.
"""

from __future__ import annotations

import csv
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from quad_dob_baselines import make_controller
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.metrics import flight_metrics
from quad_dob_training.evaluation.report import write_report
from quad_dob_training.rollout import fly

PAPER_SCENARIOS = ("paper-none", "paper-I", "paper-II", "paper-IIA", "ground-effect-landing")
PAPER_CONTROLLERS = ("geometric", "geometric-ndob", "geometric-ndob:tuned", "pid", "smc")
# the figures compare no observer with the observer, as the paper's do
FIGURE_CONTROLLERS = ("geometric", "geometric-ndob", "geometric-ndob:tuned")

COLUMNS = [
    ("rms_position", "RMS ‖e_x‖ [m]"), ("rms_x", "x"), ("rms_y", "y"), ("rms_z", "z"),
    ("rms_attitude", "RMS ‖log RdᵀR‖ [rad]"), ("rms_tilt", "tilt"), ("rms_heading", "heading"),
    ("rms_position_settled", "RMS ‖e_x‖, t≥2 s [m]"),
    ("rms_attitude_settled", "RMS ‖log RdᵀR‖, t≥2 s [rad]"),
    ("final_position_error", "final ‖e_x‖ [m]"),
    ("final_estimate_error", "final ‖d̂x − d_x‖ [N]"), ("peak_thrust", "peak thrust [N]"),
]


def build_scenarios(names: list[str], torque_reading: str, dt: float | None,
                    substeps: int | None) -> list:
    options = {k: v for k, v in (("dt", dt), ("substeps", substeps)) if v is not None}
    return [make_scenario(name, **options,
                          **({"torque_reading": torque_reading}
                             if name.startswith("paper-") else {}))
            for name in names]


def run_paper(scenarios: list[str] = list(PAPER_SCENARIOS),  # noqa: B006
              controllers: list[str] = list(PAPER_CONTROLLERS),  # noqa: B006
              torque_reading: str = "0.6*dx", dt: float | None = None,
              substeps: int | None = None, out_dir: Path | None = None,
              figures: bool = True) -> list[dict]:
    """Fly every controller in every scenario; return one metrics row per pair."""
    built = build_scenarios(scenarios, torque_reading, dt, substeps)
    warm_up(built[0])  # compile once here, before the pool forks
    flown = parallel_map(_fly_named, controllers, [built] * len(controllers))
    flights = dict(zip(controllers, flown, strict=True))
    rows = [flight_metrics(flights[c][i]) for i in range(len(built)) for c in controllers]
    if out_dir is not None:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "table.md").write_text(markdown_table(rows) + "\n")
        with open(out_dir / "table.csv", "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        if figures:
            compared = [c for c in controllers if c in FIGURE_CONTROLLERS] or controllers
            draw_figures([[flights[c][i] for c in compared] for i in range(len(built))],
                         out_dir / "figures")
            write_report(out_dir / "report.html", "quad-dob paper",
                         rows, [("scenario", "scenario"), ("controller", "controller"),
                                *COLUMNS, ("ended", "ended")],
                         {s.name: [flights[c][i] for c in controllers]
                          for i, s in enumerate(built)})
    return rows


def _fly_named(name: str, scenarios: list) -> list:
    return fly(make_controller(name, scenarios[0].vehicle), scenarios)


def warm_up(scenario) -> None:
    """Compile the step kernels (numba) in this process, so forked workers inherit them."""
    core = QuadrotorBatch(scenario, 1)
    core.reset(np.zeros(1, dtype=np.intp), [np.random.default_rng(0)])
    core.step(np.zeros((1, 4)))


def parallel_map(function, *iterables) -> list:
    """``list(map(function, *iterables))``, over two or more cores in forked processes."""
    items = list(zip(*iterables, strict=True))
    workers = min(len(items), os.cpu_count() or 1)
    if workers < 2 or sys.platform != "linux":
        return [function(*item) for item in items]
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
        return list(pool.map(function, *zip(*items, strict=True)))


def draw_figures(per_scenario: list[list], out_dir: Path) -> None:
    """Each scenario's figures (matplotlib is the slow part, so in parallel)."""
    from quad_dob_training.evaluation.plots import scenario_figures

    parallel_map(scenario_figures, per_scenario, [out_dir] * len(per_scenario))


def markdown_table(rows: list[dict]) -> str:
    header = "| scenario | controller | " + " | ".join(t for _, t in COLUMNS) + " | ended |"
    lines = [header, "|" + "---|" * (len(COLUMNS) + 3)]
    for row in rows:
        cells = ["—" if row[key] is None else f"{row[key]:.1f}" if key == "peak_thrust"
                 else f"{row[key]:.4f}" for key, _ in COLUMNS]
        lines.append(f"| {row['scenario']} | {row['controller']} | " + " | ".join(cells)
                     + f" | {row['ended']} |")
    return "\n".join(lines)


def main(scenarios: list[str], controllers: list[str], torque_reading: str,
         dt: float | None, substeps: int | None, out_dir: Path, as_json: bool,
         figures: bool) -> int:
    start = time.perf_counter()
    rows = run_paper(scenarios, controllers, torque_reading, dt, substeps, out_dir, figures)
    if as_json:
        import json

        print(json.dumps(rows, indent=1))
        return 0
    print(markdown_table(rows))
    print(f"\nThrust limit {rows[0]['thrust_limit']:.0f} N. Written to {out_dir}/ "
          f"(table.md, table.csv{', figures/, report.html' if figures else ''}) in "
          f"{time.perf_counter() - start:.1f} s.")
    return 0
