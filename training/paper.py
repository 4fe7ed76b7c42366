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
import textwrap
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from quad_dob_baselines import make_controller
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.console import WIDTH, text_table
from quad_dob_training.evaluation.metrics import flight_metrics
from quad_dob_training.evaluation.report import write_report
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rollout import fly, warm_up_copy

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
              figures: bool = True, progress: bool = False) -> list[dict]:
    """Fly every controller in every scenario; return one metrics row per pair.
    ``progress``: report on standard error (``quad_dob_training.progress``): a notice while
    a first run compiles, then each controller and each scenario's figures as they finish."""
    built = build_scenarios(scenarios, torque_reading, dt, substeps)
    warm_up(controllers, built)  # compile once here, under a notice, before forking
    flown = parallel_map(_fly_named, controllers, [built] * len(controllers),
                         label="paper" if progress else None)
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
                         out_dir / "figures", "paper figures" if progress else None)
            if progress:
                print(f"paper: writing {out_dir / 'report.html'}", file=sys.stderr,
                      flush=True)
            write_report(out_dir / "report.html", "quad-dob paper",
                         rows, [("scenario", "scenario"), ("controller", "controller"),
                                *COLUMNS, ("ended", "ended")],
                         {s.name: [flights[c][i] for c in controllers]
                          for i, s in enumerate(built)})
    return rows


def _fly_named(name: str, scenarios: list) -> list:
    return fly(make_controller(name, scenarios[0].vehicle), scenarios)


def warm_up(controllers: list[str], scenarios: list) -> None:
    """Fly each controller for a few steps of the scenarios, in this process: a first run
    compiles the kernels (numba) here, under a notice that says so, and the forked
    workers inherit them."""
    short = [warm_up_copy(scenario)
             for scenario in scenarios]
    with compiling_notice():
        for name in controllers:
            _fly_named(name, short)


def parallel_map(function, *iterables, label: str | None = None,
                 names: Sequence[str] | None = None) -> list:
    """``list(map(function, *iterables))``, over two or more cores in forked processes;
    with a ``label``, each item reported as it finishes (``progress.Progress``), by its name
    in ``names`` (default: its first argument)."""
    items = list(zip(*iterables, strict=True))
    names = [str(item[0]) for item in items] if names is None else list(names)
    workers = min(len(items), os.cpu_count() or 1)
    if workers < 2 or sys.platform != "linux":
        results = []
        with Progress(label or "", len(items), quiet=label is None) as report:
            for name, item in zip(names, items, strict=True):
                report.start(name)
                results.append(function(*item))
                report.done()
        return results
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
        # every worker forked before the reporter's thread starts: a fork while another
        # thread holds the stream's lock would leave the child's copy of it locked
        futures = {pool.submit(function, *item): k for k, item in enumerate(items)}
        results: list = [None] * len(items)
        with Progress(label or "", len(items), quiet=label is None) as report:
            for future in as_completed(futures):
                results[futures[future]] = future.result()
                # the unit is named as it finishes: the workers run several at once
                report.start(names[futures[future]])
                report.done()
        return results


def draw_figures(per_scenario: list[list], out_dir: Path, label: str | None = None) -> None:
    """Each scenario's figures (matplotlib is the slow part, so in parallel); with a
    ``label``, each reported as it is drawn."""
    from quad_dob_training.evaluation.plots import scenario_figures

    parallel_map(scenario_figures, per_scenario, [out_dir] * len(per_scenario), label=label,
                 names=[flights[0].scenario for flights in per_scenario])


def markdown_table(rows: list[dict]) -> str:
    header = "| scenario | controller | " + " | ".join(t for _, t in COLUMNS) + " | ended |"
    lines = [header, "|" + "---|" * (len(COLUMNS) + 3)]
    for row in rows:
        cells = ["—" if row[key] is None else f"{row[key]:.1f}" if key == "peak_thrust"
                 else f"{row[key]:.4f}" for key, _ in COLUMNS]
        lines.append(f"| {row['scenario']} | {row['controller']} | " + " | ".join(cells)
                     + f" | {row['ended']} |")
    return "\n".join(lines)


# what the console shows of COLUMNS (table.md and table.csv hold them all), and the
# factor to its unit
PAPER_CONSOLE_COLUMNS = (("rms_position", "RMS ‖e_x‖ [mm]", 1e3, 1),
                   ("rms_position_settled", "t≥2 s [mm]", 1e3, 1),
                   ("rms_attitude_settled", "‖log RdᵀR‖ [mrad]", 1e3, 1),
                   ("final_position_error", "final ‖e_x‖ [mm]", 1e3, 1),
                   ("final_estimate_error", "final ‖d̂x − d_x‖ [N]", 1.0, 3),
                   ("peak_thrust", "peak thrust [N]", 1.0, 1))


def console_table(rows: list[dict]) -> str:
    """The table as the console shows it: one flight per row, so no ± to name."""
    header = ["scenario", "controller", *(label for _, label, _, _ in PAPER_CONSOLE_COLUMNS),
              "ended"]
    lines, shown = [], None
    for row in rows:
        cells = ["—" if row[key] is None else f"{row[key] * scale:.{digits}f}"
                 for key, _, scale, digits in PAPER_CONSOLE_COLUMNS]
        lines.append([row["scenario"] if row["scenario"] != shown else "",
                      row["controller"], *cells, row["ended"]])
        shown = row["scenario"]
    return text_table(header, lines)


def main(scenarios: list[str], controllers: list[str], torque_reading: str,
         dt: float | None, substeps: int | None, out_dir: Path, as_json: bool,
         figures: bool) -> int:
    start = time.perf_counter()
    print(f"paper: {len(controllers)} controllers x {len(scenarios)} scenarios, one flight "
          f"each" + ("" if as_json else f", into {out_dir}"), file=sys.stderr, flush=True)
    rows = run_paper(scenarios, controllers, torque_reading, dt, substeps, out_dir, figures,
                     progress=True)
    if as_json:
        import json

        print(json.dumps(rows, indent=1))
        return 0
    print(console_table(rows))
    print("\nOne flight per row, seed 0; every column, "
          "with each axis: table.md and table.csv.")
    print("\n" + textwrap.fill(
        f"Thrust limit {rows[0]['thrust_limit']:.0f} N. Written to {out_dir}/ (table.md, "
        f"table.csv{', figures/, report.html' if figures else ''}) in "
        f"{time.perf_counter() - start:.1f} s.", WIDTH, break_long_words=False,
        break_on_hyphens=False))
    return 0
