"""``quad-dob wind-tunnel``: the four simulated counterparts of Neural-Fly's controllers
(``published.counterparts``: v1-v3's stand-ins, ``COUNTERPARTS``; v4's, the laws they
flew, ``COUNTERPARTS_V4``) on the figure-8 in 0, 4.2, 8.5 and 12.1 m/s of wind, and,
given a folder of Neural-Fly's experiment CSVs, their real flights, each side scored by the
same code (``flight_statistics``) over the same whole laps after 5 s.

Each (controller, wind) flies one vector env of one vehicle per seed; its ``info`` at each
step becomes a ``FlightLog`` (``flight_logs.InfoRecorder``). With ``--neural-fly`` the
simulated flights last the logs' span (50 s) and both sides are scored over the whole laps
both hold. Prints the published RMS beside the simulated one per wind, the simulated
statistics, and with the logs each real run beside its counterpart (the runs without one
real only); writes ``wind_tunnel.json`` (every statistic) and PNG figures under ``--out``.
"""

from __future__ import annotations

import json
import math
import sys
import textwrap
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from quad_dob_env.benchmark import TOOLS_BENCHMARK
from quad_dob_training.evaluation.console import WIDTH, text_table
from quad_dob_training.evaluation.statistics import z_share
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rollout import warm_up_copy
from quad_dob_training.wind_tunnel.flight_logs import NEURAL_FLY_METHODS, FlightLog
from quad_dob_training.wind_tunnel.flight_statistics import (
    HARMONICS,
    SKIP,
    LogStatistics,
    fa_reconstruction_rms,
    lap_window,
    log_statistics,
)
from quad_dob_training.wind_tunnel.published import (
    NEURAL_FLY_RMS,
    WIND_SPEEDS,
    counterparts,
    side_by_side,
)
from quad_dob_training.wind_tunnel.verdicts import verdicts

# the sim's first whole lap after 5 s ends at 4π s: a shorter flight has none to score
MIN_DURATION = 4 * math.pi


def fly_logs(spec: str, scenario: Any, seeds: list[int], wind_speed: float | None = None
             ) -> list[FlightLog]:
    """One episode of controller ``spec`` per seed in ``scenario``, all in one vector env,
    each as the ``FlightLog`` its ``info`` makes (stopped at its episode's end)."""
    from quad_dob_composition import make_vector_env
    from quad_dob_training.policies import make_policy
    from quad_dob_training.wind_tunnel.flight_logs import InfoRecorder

    policy = make_policy(spec, benchmark=scenario.loop.benchmark)
    if policy.model is not None:
        raise ValueError(f"{spec!r} is a trained model; the wind tunnel flies controllers "
                         f"by name: {', '.join(counterparts(scenario.loop.benchmark))}")
    env = make_vector_env(len(seeds), scenario, **policy.env_kwargs())
    _, info = env.reset(seed=[int(seed) for seed in seeds])
    recorder, actions = InfoRecorder(len(seeds)), np.zeros((len(seeds), 4))
    for _ in range(scenario.steps):
        recorder.add(info)  # the state this step's command is planned from, and the command
        _, _, terminated, truncated, info = env.step(actions)  # a residual of zero
        if not recorder.ended(terminated, truncated):
            break
    env.close()
    return recorder.logs(env.core.vehicle,
                         [f"simulated: {spec}, {scenario.name}, seed {s}" for s in seeds],
                         method=spec, condition=scenario.name, wind_speed=wind_speed)


def flat(statistics: LogStatistics) -> dict[str, float]:
    """The scalars of ``statistics`` by a dotted name (``rms.z``, ``harmonics.2.z``, ...)."""
    found = asdict(statistics)
    values: dict[str, float] = {"laps": statistics.window.laps}
    for key, value in found.items():
        if key == "harmonics":
            values.update({f"harmonics.{h['harmonic']}.{axis}": h["amplitude"][axis]
                           for h in value for axis in "xyz"})
            values.update({f"harmonics.{h['harmonic']}.phase.{axis}": h["phase"][axis]
                           for h in value for axis in "xyz"})
        elif isinstance(value, dict) and key != "window":
            values.update({f"{key}.{name}": entry for name, entry in value.items()})
        elif key != "window":
            values[key] = value
    return values


def pooled(per_seed: list[dict[str, float]]) -> dict[str, float]:
    """The mean over the seeds of each statistic; the z share pooled, Σ rms_z² / Σ rms²; a
    phase by its circular mean (the angle of the mean unit vector: -179° and 179° average
    to 180°, not 0°)."""
    if not per_seed:
        return {}
    mean = {key: float(np.mean([values[key] for values in per_seed])) for key in per_seed[0]}
    for key in (key for key in per_seed[0] if ".phase." in key):
        angles = np.array([values[key] for values in per_seed])
        mean[key] = float(np.arctan2(np.mean(np.sin(angles)), np.mean(np.cos(angles))))
    mean["z_share"] = z_share([[values[f"rms.{axis}"] for axis in "xyz"]
                               for values in per_seed])
    return mean


def rms_after_skip(log: FlightLog) -> float:
    """RMS ‖p - p_d‖ over the samples after ``SKIP`` s; NaN for a flight lost before it."""
    after = (log.p - log.p_d)[log.t >= SKIP]
    if not len(after):
        return float("nan")
    return float(np.sqrt(np.mean(np.sum(after ** 2, axis=1))))


def simulate(benchmark: str, seeds: list[int], duration: float | None,
             laps_wanted: set[int], scenario_options: dict[str, Any] | None = None,
             pairs: dict[str, str] | None = None, progress: bool = False
             ) -> list[dict[str, Any]]:
    """Every counterpart in every wind: per seed the RMS after 5 s and the statistics over
    its own whole laps, and over each count in ``laps_wanted`` (a real log's).
    ``scenario_options`` go to every figure-8 (``make_scenario``'s keywords: the ablation
    switches a factor with them); ``pairs`` (simulated -> real) the counterparts flown,
    the benchmark's by default (``published.counterparts``). ``progress``: report on
    standard error, a notice while a first run compiles, then each wind and controller."""
    pairs = counterparts(benchmark) if pairs is None else pairs
    from quad_dob_env.scenarios import make_scenario

    options: dict[str, Any] = {"benchmark": benchmark, **(scenario_options or {})}
    if duration is not None:
        options["duration"] = duration
    if progress:  # a first run compiles here, under a notice that says so
        from quad_dob_training.policies import fly_policy, make_policy

        first = warm_up_copy(make_scenario(f"figure8-wind-{WIND_SPEEDS[0]}", **options))
        with compiling_notice():
            for spec in pairs:
                fly_policy(make_policy(spec, benchmark=benchmark), first, seeds)
    results = []
    with Progress("wind-tunnel", len(WIND_SPEEDS) * len(pairs),
                  quiet=not progress) as reporter:
        for wind in WIND_SPEEDS:
            scenario = make_scenario(f"figure8-wind-{wind}", **options)
            for spec in pairs:
                reporter.start(f"{spec}, {wind} m/s")
                results.append(_flown_in_tunnel(spec, scenario, seeds, float(wind), pairs,
                                                 laps_wanted))
                reporter.done(f"{results[-1]['crashes']} of {len(seeds)} lost")
    return results


def _flown_in_tunnel(spec: str, scenario: Any, seeds: list[int], wind: float,
                     pairs: dict[str, str], laps_wanted: set[int]) -> dict[str, Any]:
    """``simulate``'s record of one controller in one wind."""
    logs = fly_logs(spec, scenario, seeds, wind)
    scored = [log for log in logs if not log.crashed]
    own = lap_window(scored[0]).laps if scored else 0
    by_laps = {str(laps): [flat(log_statistics(log, laps)) for log in scored]
               for laps in {own, *laps_wanted} if 1 <= laps <= own}
    return {
        "policy": spec, "counterpart": pairs[spec], "wind_speed": wind,
        "scenario": scenario.name, "duration": scenario.duration,
        "flights": len(logs), "crashes": int(sum(log.crashed for log in logs)),
        # the seeds of the per-seed statistics: a lost flight is not scored on laps
        "scored_seeds": [seed for seed, log in zip(seeds, logs, strict=True)
                         if not log.crashed],
        "thrust_source": logs[0].thrust_source, "laps": own,
        "rms_after_skip": [rms_after_skip(log) for log in logs],
        "per_seed": by_laps, "mean": {laps: pooled(values)
                                      for laps, values in by_laps.items()}}


def compare_real(real: list[FlightLog], simulated: list[dict[str, Any]]
                 ) -> list[dict[str, Any]]:
    """Each real log's statistics, its fa reconstruction's RMS against its own fa, and its
    counterpart's mean over the same number of whole laps (None: no counterpart: NF,
    NF-T). The counterparts are the ones ``simulated`` flew."""
    flown = {run["counterpart"]: run["policy"] for run in simulated}
    rows = []
    for log in real:
        spec = flown.get(NEURAL_FLY_METHODS.get(log.method))
        match = next((run for run in simulated if run["policy"] == spec
                      and run["wind_speed"] == log.wind_speed), None)
        laps = lap_window(log).laps
        if match is not None:
            laps = min(laps, match["laps"]) or laps
        statistics = flat(log_statistics(log, laps))
        fa_rms = asdict(fa_reconstruction_rms(log)) if log.fa is not None else None
        simulated_mean = None if match is None else match["mean"].get(str(laps))
        rows.append({"file": Path(log.source).name, "method": log.method,
                     "condition": log.condition, "wind_speed": log.wind_speed,
                     "counterpart": spec if match is not None else None,
                     "laps": laps, "statistics": statistics,
                     "fa_reconstruction_rms": fa_rms, "simulated": simulated_mean,
                     "verdicts": None if simulated_mean is None else verdicts(
                         statistics, simulated_mean, log.wind_speed)})
    return rows


COLUMNS = (("laps", "laps", 1.0, ".0f"), ("rms.x", "RMS x", 1e3, ".1f"),
           ("rms.y", "y", 1e3, ".1f"), ("rms.z", "z", 1e3, ".1f"),
           ("rms_total", "all [mm]", 1e3, ".1f"), ("mean.x", "mean x", 1e3, ".1f"),
           ("mean.y", "y", 1e3, ".1f"), ("mean.z", "z [mm]", 1e3, ".1f"),
           ("z_share", "z share", 1.0, ".2f"),
           *((f"harmonics.{k}.{axis}", f"{axis} at {k} rad/s [mm]", 1e3, ".1f")
             for axis in "xz" for k in HARMONICS),
           ("fa_z_fit.a", "fit a [kg]", 1.0, ".3f"), ("fa_z_fit.b", "b [kg/s]", 1.0, ".3f"),
           ("fa_z_fit.c", "c [N]", 1.0, ".2f"), ("fa_z_fit.r_squared", "R²", 1.0, ".2f"),
           ("fa_z_fit.tau", "τ [ms]", 1e3, ".0f"), ("mean_fa_x", "mean fa_x [N]", 1.0, ".2f"),
           ("hover_throttle_start", "hover start", 1.0, ".3f"),
           ("hover_throttle_end", "end", 1.0, ".3f"),
           ("harmonics.2.phase.z", "z phase at 2 rad/s [°]", 180 / math.pi, ".0f"),
           ("lap_periodic_share", "lap-periodic share", 1.0, ".2f"),
           ("command_over_hover_mean", "command / hover mean", 1.0, ".2f"),
           ("command_over_hover_peak", "peak", 1.0, ".2f"),
           ("limit_share", "at a limit [%]", 100.0, ".1f"))


def _cells(values: dict[str, float] | None, columns: Sequence[tuple] = COLUMNS) -> list[str]:
    if not values:
        return ["—"] * len(columns)
    return ["—" if values.get(key) is None or not np.isfinite(values[key])
            else format(values[key] * scale, spec) for key, _, scale, spec in columns]


def statistics_table(first: list[str], rows: list[tuple[list[str], dict | None]]) -> str:
    header = [*first, *(label for _, label, _, _ in COLUMNS)]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join([*names, *_cells(values)]) + " |" for names, values in rows]
    return "\n".join(lines)


def _published_comparison(benchmark: str, simulated: list[dict]) -> tuple[str, str]:
    """The title and the Markdown table of the simulated RMS after ``SKIP`` s beside
    Neural-Fly's published figures (``side_by_side``)."""
    rows = [{"scenario": run["scenario"], "policy": run["policy"],
             "rms_position_settled_mean": float(np.mean(run["rms_after_skip"])),
             "crashes": run["crashes"]} for run in simulated]
    return (f"Benchmark {benchmark}: RMS position error after {SKIP:g} s [mm], the simulated "
            "mean over the seeds beside Neural-Fly's published figure",
            side_by_side(rows, "controller",
                         {run["policy"]: run["counterpart"] for run in simulated}))


def report(benchmark: str, simulated: list[dict], real_rows: list[dict]) -> str:
    """Every table of ``quad-dob wind-tunnel`` in full, as Markdown: wind_tunnel.md."""
    parts = [*_published_comparison(benchmark, simulated), "",
             "Simulated, over the whole laps after 5 s (mean over the seeds; z share "
             "pooled: Σ rms_z² / Σ rms²)",
             statistics_table(["controller", "wind [m/s]", "lost"], [
                 ([run["policy"], f"{run['wind_speed']:g}", str(run["crashes"])],
                  run["mean"].get(str(run["laps"]))) for run in simulated])]
    if real_rows:
        table = []
        for row in real_rows:
            name = f"{row['method']} {row['condition']}"
            table.append(([name, "real"], row["statistics"]))
            if row["counterpart"] is not None:
                table.append(([name, f"sim: {row['counterpart']}"], row["simulated"]))
        alone = sum(row["counterpart"] is None for row in real_rows)
        parts += ["", f"Neural-Fly's runs beside their simulated counterparts over the same "
                      f"whole laps ({alone} runs without a counterpart: real only)",
                  statistics_table(["run", "side"], table)]
        parts += ["", "Sim against real: a verdict where Benchmark v4's targets give a "
                      "tolerance, else the ratio", verdict_table(real_rows)]
    return "\n".join(parts)


# what the console shows of COLUMNS (wind_tunnel.md holds them all)
TUNNEL_CONSOLE_COLUMNS = ("laps", "rms.x", "rms.y", "rms.z", "rms_total", "z_share",
                   "command_over_hover_peak", "limit_share")


def console_report(benchmark: str, simulated: list[dict], real_rows: list[dict]) -> str:
    """What ``quad-dob wind-tunnel`` prints, in 120 columns: the published comparison, the
    simulated laps' main statistics, and how many of the real runs' statistics each verdict
    holds; ``report`` (wind_tunnel.md) has every column."""
    shown = [column for column in COLUMNS if column[0] in TUNNEL_CONSOLE_COLUMNS]
    labels = {"rms.x": "RMS x [mm]", "rms.y": "y [mm]", "rms.z": "z [mm]",
              "command_over_hover_peak": "command / hover peak"}
    table = text_table(
        ["controller", "wind [m/s]", "lost", *(labels.get(key, label)
                                               for key, label, _, _ in shown)],
        [[run["policy"], f"{run['wind_speed']:g}", str(run["crashes"]),
          *_cells(run["mean"].get(str(run["laps"])), shown)] for run in simulated], names=1)
    title, published = _published_comparison(benchmark, simulated)
    parts = [title, text_table(*_markdown_rows(published), names=1), "",
             "Simulated, over the whole laps after 5 s (mean over the seeds; z share pooled: "
             "Σ rms_z² / Σ rms²)", table]
    if real_rows:
        verdicts = [str(entry["verdict"]).split(":")[0] for row in real_rows
                    for entry in row["verdicts"] or ()]
        parts += ["", textwrap.fill(
            f"Sim against real over the same whole laps, {len(real_rows)} runs: "
            f"{verdicts.count('within')} statistics within their target's tolerance, "
            f"{verdicts.count('outside')} outside (each statistic and the ratios where no "
            "target applies: wind_tunnel.md)", WIDTH)]
    return "\n".join(parts)


def _markdown_rows(markdown: str) -> tuple[list[str], list[list[str]]]:
    """A markdown table's header and rows, as cells."""
    lines = [[cell.strip() for cell in line.strip().strip("|").split("|")]
             for line in markdown.splitlines() if line.startswith("|")]
    return lines[0], [line for line in lines[2:]]


def verdict_table(real_rows: list[dict]) -> str:
    """Every run with a counterpart: each statistic's real and simulated value and verdict."""
    lines = ["| run | counterpart | statistic | real | sim | verdict |",
             "|---|---|---|---|---|---|"]
    for row in real_rows:
        for entry in row["verdicts"] or ():
            shown = ["—" if entry[side] is None or not np.isfinite(entry[side])
                     else f"{entry[side]:.3g}{' ' + entry['unit'] if entry['unit'] else ''}"
                     for side in ("real", "simulated")]
            lines.append(f"| {row['method']} {row['condition']} | {row['counterpart']} | "
                         f"{entry['statistic']} | {shown[0]} | {shown[1]} | "
                         f"{entry['verdict']} |")
    return "\n".join(lines)


def _plain(value: Any) -> Any:
    """JSON's own types; NaN as null."""
    if isinstance(value, dict):
        return {str(key): _plain(entry) for key, entry in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(entry) for entry in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def main(benchmark: str | None, seeds: str, neural_fly: Path | None, out: Path,
         duration: float | None = None, chosen: str | None = None) -> int:
    """The command: fly, score, print, and write ``wind_tunnel.json`` and the figures."""
    from quad_dob_training.evaluation.evaluate import parse_seeds
    from quad_dob_training.wind_tunnel.flight_logs import read_neural_fly_folder
    from quad_dob_training.wind_tunnel.plots import write_figures

    benchmark = benchmark or TOOLS_BENCHMARK
    real = [] if neural_fly is None else read_neural_fly_folder(neural_fly)
    if duration is None and real:
        # the logs' span, on the simulation's 10 ms grid
        duration = round(max(float(log.t[-1] - log.t[0]) for log in real), 2)
    if duration is not None and duration < MIN_DURATION:
        raise ValueError(f"--duration {duration:g} s holds no whole lap after {SKIP:g} s: the "
                         f"figure-8's first one ends at 4π = {MIN_DURATION:.2f} s; give "
                         f"{MIN_DURATION:.2f} s or more")
    seed_list = parse_seeds(seeds, round((duration or 30.0) / 0.01))
    pairs = counterparts(benchmark, chosen)
    print(f"wind-tunnel: {len(pairs)} controllers x {len(WIND_SPEEDS)} winds x "
          f"{len(seed_list)} seeds, Benchmark {benchmark}, into {out}", file=sys.stderr,
          flush=True)
    simulated = simulate(benchmark, seed_list, duration,
                         {lap_window(log).laps for log in real}, pairs=pairs, progress=True)
    real_rows = compare_real(real, simulated)
    print(console_report(benchmark, simulated, real_rows))
    out.mkdir(parents=True, exist_ok=True)
    (out / "wind_tunnel.md").write_text(report(benchmark, simulated, real_rows) + "\n")
    document = {"benchmark": benchmark, "seeds": seed_list, "skip": SKIP,
                "published_rms": {label: dict(zip(WIND_SPEEDS, values, strict=True))
                                  for label, values in NEURAL_FLY_RMS.items()},
                "simulated": simulated, "real": real_rows}
    (out / "wind_tunnel.json").write_text(json.dumps(_plain(document), indent=1) + "\n")
    figures = write_figures(simulated, real_rows, out)
    print("\n" + textwrap.fill(f"wrote into {out}/: wind_tunnel.md (every column), "
                               "wind_tunnel.json, " + ", ".join(path.name for path in figures),
                               WIDTH, break_long_words=False, break_on_hyphens=False))
    return 0
