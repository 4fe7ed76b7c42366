"""``quad-dob evaluate``: every policy on every scenario over the given seeds.

Scores (``quad_dob_training.evaluation.metrics``, the code ``quad-dob paper`` uses), after t = 2 s:
RMS position error, RMS geodesic attitude error ‖log RdᵀR‖, RMS tilt error ∠(b3, b3d), RMS
heading error, control effort (RMS applied moment norm), and the crash rate. Each score
gets its mean, std and 95 % bootstrap interval over the seeds, and every policy its paired
per-seed difference to ``baseline`` (default the recommended geometric + NDOB) with a 95 %
bootstrap interval (``quad_dob_training.evaluation.statistics``): "better" means that interval lies
below zero.

Writes ``evaluation.md``, ``evaluation.csv``, ``evaluation.json`` (the rows with their
provenance, in the schema others' results merge by: ``quad_dob_training.evaluation.results``),
``evaluation.png`` (bars with their 95 % intervals) and the interactive ``report.html``
(figures of the first seed), or prints the rows as JSON. JSON and CSV keys:
``{score}_mean``, ``_std``, ``_low``, ``_high`` for each score (and for the settled RMS
per axis, ``rms_position_settled_{x,y,z}``), ``{score}_diff_mean``, ``_diff_low``,
``_diff_high`` against ``baseline``; ``z_share_settled`` = Σ rms_z² / Σ rms² over the seeds.
"""

from __future__ import annotations

import csv
import json
import sys
import textwrap
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from quad_dob_baselines import gain_set
from quad_dob_env import DEFAULT_BASE_CONTROLLER
from quad_dob_env.benchmark import TOOLS_BENCHMARK
from quad_dob_env.scenarios import Scenario, make_scenario
from quad_dob_training.evaluation.console import WIDTH, evaluation_table, ranking_lines
from quad_dob_training.evaluation.margins import benchmark_delay_path, check_grid, delay_margin
from quad_dob_training.evaluation.metrics import flight_metrics
from quad_dob_training.evaluation.plots import evaluation_bars
from quad_dob_training.evaluation.ranking import Standing, ranked
from quad_dob_training.evaluation.report import write_report
from quad_dob_training.evaluation.results import (
    merged_leaderboard,
    read_document,
    results_document,
    source_labels,
    write_document,
)
from quad_dob_training.evaluation.statistics import (
    bootstrap_mean,
    paired_difference,
    z_share,
)
from quad_dob_training.policies import (
    LIBRARY_BENCHMARK,
    SHIPPED_TRAINED_IN,
    Policy,
    fly_policy,
    make_policy,
    resolve_spec,
    shipped_policy_advice,
)
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rollout import check_flight_memory, warm_up_copy

SCORES = (("rms_position_settled", "RMS ‖e_x‖ [m]"),
          ("rms_attitude_settled", "RMS ‖log RdᵀR‖ [rad]"),
          ("rms_tilt_settled", "RMS tilt [rad]"),
          ("rms_heading_settled", "RMS heading [rad]"),
          ("rms_moment", "effort: RMS ‖M‖ [N m]"))
# the settled RMS position error per axis, each with its mean, std and interval as SCORES
AXIS_SCORES = tuple(f"rms_position_settled_{axis}" for axis in "xyz")
# what the controllers read against the truth (zero with ideal sensing)
ESTIMATOR_SCORES = ("rms_estimate_position_settled", "rms_estimate_velocity_settled",
                    "rms_estimate_attitude_settled")
# the paired difference to the baseline is reported for these
COMPARED = ("rms_position_settled", "rms_attitude_settled", "rms_moment")
# --suite: every scenario family of the benchmark, by what it asks of a policy. v2 cannot
# fly the wrench-actuated paper-* scenarios: its force family has their rotor-actuated
# counterpart, and it adds Neural-Fly's wind-tunnel figure-8s, flown on their vehicle.
SUITES = {
    "v1": {
        "wind": ("dryden-helix", "dryden-helix-gusts", "gusty-hover", "takeoff-landing-wind"),
        "calm": ("paper-none", "hover-calm", "ground-effect-landing"),
        "forces": ("paper-I", "paper-II", "paper-IIA", "hover-step-force"),
        # random references in randomised wind: the training pool (on unseen seeds), and a
        # kind held out of training
        "references": ("random-tracks", "random-lemniscates"),
    },
    "v2": {
        "wind": ("dryden-helix", "dryden-helix-gusts", "gusty-hover", "takeoff-landing-wind"),
        "calm": ("hover-calm", "ground-effect-landing"),
        "forces": ("helix-force-torque", "hover-step-force"),
        "references": ("random-tracks", "random-lemniscates"),
        # issue 29's held-out families: pools seeded apart from training's, one of them a
        # kind no training family holds (quad_dob_env.scenarios.HELD_OUT_POOL_SEED)
        "held-out": ("heldout-tracks", "heldout-hops"),
        "wind-tunnel": ("figure8-wind-0", "figure8-wind-4.2", "figure8-wind-8.5",
                        "figure8-wind-12.1"),
    },
}
# v3 flies v2's families in its own loop (the figure-8s at Neural-Fly's 50 Hz)
SUITES["v3"] = SUITES["v2"]
SUITES["v4"] = SUITES["v2"]  # and v4, v3's loop with five mechanisms corrected
# the leaderboard's cells: mean [95 % CI]
LEADERBOARD = (("rms_position_settled", "RMS ‖e_x‖ [m]"), ("rms_tilt_settled", "tilt [rad]"),
               ("rms_heading_settled", "heading [rad]"), ("rms_moment", "effort ‖M‖ [N m]"),
               ("crash_rate", "crash rate"))


# the flight length parse_seeds sizes a seed range by: 10 s at 100 Hz, the longest v1
# scenario's (fly_policy checks each scenario's own length again before it flies)
FLIGHT_STEPS = 1000


def parse_seeds(text: str, steps: int = FLIGHT_STEPS) -> list[int]:
    """``"20"`` -> seeds 0-19; ``"9001-9020"`` -> those 20 seeds (inclusive).

    A range whose flights of ``steps`` steps would pass the memory budget
    (``quad_dob_env.memory``) is refused before any list is built."""
    text = str(text).strip()
    try:
        if "-" in text:
            first, last = (int(part) for part in text.split("-", 1))
            if last < first:
                raise ValueError
        else:
            first, last = 0, int(text) - 1
            if last < 0:
                raise ValueError
    except ValueError:
        raise ValueError(f"seeds must be a count >= 1 such as 20 or an inclusive range A-B "
                         f"such as 9001-9020, got {text!r}") from None
    check_flight_memory(last - first + 1, steps, f"--seeds {text}",
                        "evaluate fewer seeds (a smaller --seeds)")
    return list(range(first, last + 1))


def evaluate(policies: list[str], scenarios: list[str], seeds: list[int],
             first_flights: dict | None = None,
             baseline: str | None = DEFAULT_BASE_CONTROLLER, *,
             trust_pickle: bool = False,
             scenario_options: dict[str, object] | None = None,
             delay_grid: Sequence[float] | None = None,
             per_seed: dict[tuple[str, str], list[dict]] | None = None,
             delay_path: str | None = None, env_id: str | None = None,
             progress: bool = False) -> list[dict]:
    """One row per (scenario, policy): mean, std and 95 % interval over seeds of each score,
    the crash rate, and the paired difference to ``baseline`` (flown too if not listed;
    None for no comparison). ``first_flights``, when given, collects each scenario's
    flights on the first seed; ``per_seed``, when given, each (scenario, policy spec)'s
    flight metrics in seed order, for comparisons the rows do not hold. ``trust_pickle``:
    model files may be unpickled (``model_files.load_model``). ``scenario_options`` go to
    every scenario (``make_scenario(name, **scenario_options)``). ``delay_grid``, when
    given: each row's ``delay_margin`` on it (``evaluation.margins``), its latency on
    ``delay_path`` (None: where the scenario's benchmark puts its margin's). ``env_id``: the
    id every model zip without a training config beside it was trained on (``--env``).
    Bare ``residual`` flies the shipped policy of each scenario's benchmark
    (``policies.resolve_spec``), and its rows name the one it flew; specs that resolve to
    the same policy in a scenario (``residual`` and ``residual:v1`` in v1) fly once and make
    one row there. ``progress``: report on standard error (``quad_dob_training.progress``):
    a notice while a first run compiles, then each scenario and policy as it is flown."""
    specs = list(dict.fromkeys(policies))
    flown = specs if baseline is None or baseline in specs else [*specs, baseline]
    made = {name: make_scenario(name, **(scenario_options or {})) for name in scenarios}
    # every policy each scenario's benchmark resolves a spec to, built before any flies (a
    # bad spec or file fails first), each once
    built_as: dict[str, object] = {}
    if progress:  # a model's load takes seconds (torch, the zip's checks)
        print(f"evaluate: loading {len(flown)} policies", file=sys.stderr, flush=True)
    for scenario in made.values():
        for spec in flown:
            resolved = resolve_spec(spec, scenario.loop.benchmark)
            if resolved not in built_as:
                built_as[resolved] = make_policy(resolved, trust_pickle=trust_pickle,
                                                 env_id=env_id)
            problem = built_as[resolved].refusal(scenario)
            if problem is not None:
                raise ValueError(f"{spec} cannot fly {scenario.name}: {problem}")
    if progress:
        warm_up(list(built_as.values()), next(iter(made.values())), seeds)
    units = sum(len({resolve_spec(spec, scenario.loop.benchmark) for spec in flown})
                for scenario in made.values())
    # silent unless asked: a library call reports nothing
    with Progress("evaluate", units, quiet=not progress) as report:
        rows = []
        for scenario_name, scenario in made.items():
            # each spec as this scenario's benchmark resolves it: two specs naming the same
            # policy here (``residual`` and ``residual:v1`` in v1) fly once and make one row
            resolved_of = {spec: resolve_spec(spec, scenario.loop.benchmark) for spec in flown}
            listed = list(dict.fromkeys(resolved_of[spec] for spec in specs))
            metrics, distinct, flights_of = {}, {}, {}
            for resolved in dict.fromkeys(resolved_of.values()):
                report.start(f"{scenario_name}, {built_as[resolved].name}")
                flights = flights_of[resolved] = fly_policy(built_as[resolved], scenario, seeds)
                metrics[resolved] = [flight_metrics(f) for f in flights]
                lost = sum(bool(m["crashed"]) for m in metrics[resolved])
                report.done(f"{len(flights)} flights" + (f", {lost} lost" if lost else ""))
                if first_flights is not None and resolved in listed:
                    first_flights.setdefault(scenario_name, []).append(flights[0])
                distinct[resolved] = distinct_flights(flights)
            if per_seed is not None:
                for spec in flown:
                    per_seed[scenario_name, spec] = metrics[resolved_of[spec]]
            compared_with = None if baseline is None else resolved_of[baseline]
            reference = None if compared_with is None else metrics[compared_with]
            for spec in listed:
                policy = built_as[spec]
                row = _row(scenario_name, policy.name, seeds, metrics[spec], compared_with,
                           reference)
                row["distinct_flights"] = distinct[spec]
                row["gains"] = _gains_used(policy, scenario)
                row.update(policy_spec=spec,
                           policy_fingerprint=policy.fingerprint or "",
                           benchmark=scenario.loop.benchmark,
                           vehicle=scenario.vehicle.name,
                           sensing=getattr(scenario.loop.sensing, "name", None) or "ideal",
                           env_entry_point=("quad_dob_composition:ResidualVectorEnv"
                                            if policy.base is not None else
                                            "quad_dob_env.envs:QuadrotorVectorEnv"),
                           env_id=(policy.config or {}).get("env_id", ""))
                if delay_grid is not None:
                    # its own flights, often the longest part: the heartbeat names it
                    report.start(f"{scenario_name}, {policy.name}: delay margin")
                    path = delay_path or benchmark_delay_path(scenario.loop.benchmark)
                    margin = delay_margin(policy, scenario_name, seeds, scenario_options,
                                          check_grid(delay_grid), flown=flights_of[spec],
                                          path=path)
                    row.update(delay_margin=margin.margin, delay_margin_path=path,
                               delay_margin_text=f"{margin.describe()} ({path})")
                rows.append(row)
        return rows


def warm_up(policies: Sequence[Policy], scenario: Scenario, seeds: list[int]) -> None:
    """Fly each of ``policies`` for a few steps of ``scenario`` on ``seeds``: a first run
    compiles the kernels here, under a notice that says so (``progress.compiling_notice``).
    The seeds are the evaluation's own: numba compiles a kernel again for arrays of another
    layout, and a batch of one vehicle lays some out differently from a batch of many."""
    short = warm_up_copy(scenario)
    with compiling_notice():
        for policy in policies:
            fly_policy(policy, short, seeds)


def _gains_used(policy, scenario) -> str:
    """Which gain set the policy's controller (or a residual's base) flew: "v2/paper",
    "v2/paper, scaled" (another vehicle flying the paper vehicle's set), "defaults" (the
    modules' own, v1's), or "" (no controller, or one given as an object)."""
    if not isinstance(policy.base, str):
        return ""
    chosen = gain_set(policy.base, policy.base_benchmark or scenario.loop.benchmark,
                      scenario.vehicle)
    if chosen.tuned_for is None:
        return "defaults"
    return "/".join(chosen.tuned_for) + (", scaled" if chosen.scaled else "")


def distinct_flights(flights: list) -> int:
    """How many of ``flights`` differ (their recorded positions, bit for bit): a scenario
    whose seeds vary nothing flies one flight however many seeds it is given."""
    return len({(flight.position.shape, flight.position.tobytes()) for flight in flights})


def _row(scenario: str, policy: str, seeds: list[int], metrics: list[dict],
         baseline: str | None, reference: list[dict] | None) -> dict:
    row: dict = {"scenario": scenario, "policy": policy,
                 "seeds": f"{seeds[0]}-{seeds[-1]}" if len(seeds) > 1 else str(seeds[0])}
    for key in (*(key for key, _ in SCORES), *AXIS_SCORES):
        values = np.array([m[key] for m in metrics], dtype=float)
        interval = bootstrap_mean(values)
        row[f"{key}_mean"] = interval.mean
        row[f"{key}_std"] = float(values.std())
        row[f"{key}_low"], row[f"{key}_high"] = interval.low, interval.high
    # the vertical share of the squared settled error, pooled over the seeds (rms² as the
    # axes' sum, which it is: the share then cannot round above 1)
    row["z_share_settled"] = z_share([[m[key] for key in AXIS_SCORES] for m in metrics])
    for key in ESTIMATOR_SCORES:
        values = np.array([m.get(key, np.nan) for m in metrics], dtype=float)
        row[f"{key}_mean"] = float(values.mean())
    # the rotor command's RMS rate [N/s] (metrics._command_rate); none under wrench actuation
    rates = [m["rms_command_rate"] for m in metrics]
    if all(rate is not None for rate in rates):
        interval = bootstrap_mean(np.array(rates, dtype=float))
        row["rms_command_rate_mean"] = interval.mean
        row["rms_command_rate_low"], row["rms_command_rate_high"] = interval.low, interval.high
    crashes = bootstrap_mean(np.array([m["crashed"] for m in metrics], dtype=float))
    row["crash_rate"] = row["crash_rate_mean"] = crashes.mean
    row["crash_rate_low"], row["crash_rate_high"] = crashes.low, crashes.high
    row["crashes"] = int(np.sum([m["crashed"] for m in metrics]))
    row["flights"] = len(metrics)
    row["baseline"] = baseline or ""
    for key in COMPARED:
        if reference is None:
            continue
        difference = paired_difference([m[key] for m in metrics], [m[key] for m in reference])
        row[f"{key}_diff_mean"] = difference.mean
        row[f"{key}_diff_low"], row[f"{key}_diff_high"] = difference.low, difference.high
    return row


def write_tables(rows: list[dict], out: Path, notes: Sequence[str] = ()) -> None:
    """evaluation.csv, evaluation.md (the table, the benchmark flown and ``notes`` under
    it) and evaluation.png."""
    out.mkdir(parents=True, exist_ok=True)
    # every row's columns, in the order first met: a row whose flights were all lost has no
    # command rate, and the first row's columns alone refused the rows that have one
    columns = list(dict.fromkeys(key for row in rows for key in row))
    with open(out / "evaluation.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=columns, restval="")
        writer.writeheader()
        writer.writerows(rows)
    flown = ", ".join(sorted({str(row.get("benchmark", "")) for row in rows} - {""}))
    under = [f"Flown in Benchmark {flown}."] if flown else []
    (out / "evaluation.md").write_text(
        "\n\n".join([markdown_table(rows), *under, *notes]) + "\n")
    evaluation_bars(rows, out / "evaluation.png")


def markdown_table(rows: list[dict]) -> str:
    """Mean ± std of each score, crashes, distinct flights, the estimator's RMS errors, the
    delay margin where it was searched, and the position error's paired difference to the
    baseline: its mean in percent of the baseline's, with its 95 % interval in metres. A
    row whose seeds fly one distinct flight says so instead of a zero-width spread."""
    baseline = rows[0].get("baseline") if rows else ""
    margins = any("delay_margin_text" in row for row in rows)
    header = ["scenario", "policy", *(label for _, label in SCORES), "command rate [N/s]",
              "crashed",
              "distinct flights", "estimate RMS ‖x̂-x‖ [m], ∠(R̂, R) [rad]"]
    if margins:
        header.append("delay margin")
    if baseline:
        header.append(f"Δ RMS ‖e_x‖ vs {baseline} [m] (95 % CI)")
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        single = _one_flight(row)
        scores = [f"{row[f'{key}_mean']:.4f}" + (" (one flight)" if single else
                                                  f" ± {row[f'{key}_std']:.4f}")
                  for key, _ in SCORES]
        rate = row.get("rms_command_rate_mean")
        cells = [row["scenario"], row["policy"], *scores,
                 "—" if rate is None else f"{rate:.1f}", f"{row['crashes']}/{row['flights']}",
                 str(row.get("distinct_flights", "")),
                 f"{row.get('rms_estimate_position_settled_mean', 0.0):.4f}, "
                 f"{row.get('rms_estimate_attitude_settled_mean', 0.0):.4f}"]
        if margins:
            cells.append(row.get("delay_margin_text", ""))
        if baseline:
            cells.append(_difference_cell(row, baseline))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _one_flight(row: dict) -> bool:
    """Whether the row's seeds all flew the same flight (no spread to speak of)."""
    return row.get("distinct_flights") == 1 and row["flights"] > 1


def leaderboard(rows: list[dict], benchmark: str = TOOLS_BENCHMARK) -> str:
    """The suite's leaderboard: per family and scenario, each policy's mean and 95 %
    bootstrap interval of every score, and its paired difference to the baseline; then each
    scenario's policies in rank, learned and classical by one rule (``ranking``: fewest
    flights lost, then the lowest mean RMS error); then, per policy, the scenarios where it
    is better or worse than the baseline (interval excluding zero)."""
    baseline = rows[0].get("baseline") if rows else ""
    family_of = {name: family for family, names in SUITES[benchmark].items()
                 for name in names}
    margins = any("delay_margin_text" in row for row in rows)
    header = ["family", "scenario", "policy", *(label for _, label in LEADERBOARD),
              "distinct flights", *(["delay margin"] if margins else [])]
    if baseline:
        header.append(f"Δ RMS ‖e_x‖ vs {baseline} [m] (95 % CI)")
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        cells = [family_of.get(row["scenario"], "other"), row["scenario"], row["policy"]]
        for key, _ in LEADERBOARD:
            cells.append(f"{row[f'{key}_mean']:.4f} [{row[f'{key}_low']:.4f}, "
                         f"{row[f'{key}_high']:.4f}]")
        cells.append(f"{row.get('distinct_flights', '')} of {row['flights']}")
        if margins:
            cells.append(row.get("delay_margin_text", ""))
        if baseline:
            cells.append(_difference_cell(row, baseline))
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| scenario | in rank: flights lost, then mean RMS ‖e_x‖ [m] |", "|---|---|"]
    for scenario in dict.fromkeys(row["scenario"] for row in rows):
        standings = {row["policy"]: Standing(int(row["crashes"]),
                                             float(row["rms_position_settled_mean"]))
                     for row in rows if row["scenario"] == scenario}
        lines.append(f"| {scenario} | " + ", ".join(
            f"{rank}. {name} ({standings[name].lost:g} lost, {standings[name].rms:.4f})"
            for rank, name in enumerate(ranked(standings), 1)) + " |")
    if baseline:
        lines += ["", f"| policy | better than {baseline} | worse | not significant | "
                      "flights lost (its own / the baseline's) |", "|---|---|---|---|---|"]
        lost_by_base = {row["scenario"]: row["crashes"] for row in rows
                        if is_baseline_row(row, baseline)}
        for policy in dict.fromkeys(row["policy"] for row in rows
                                    if not is_baseline_row(row, baseline)):
            mine = [row for row in rows if row["policy"] == policy]
            better = [r["scenario"] for r in mine if r["rms_position_settled_diff_high"] < 0]
            worse = [r["scenario"] for r in mine if r["rms_position_settled_diff_low"] > 0]
            lost = sum(r["crashes"] for r in mine)
            base_lost = sum(lost_by_base.get(r["scenario"], 0) for r in mine)
            lines.append(f"| {policy} | {len(better)}: {', '.join(better) or '—'} | "
                         f"{len(worse)}: {', '.join(worse) or '—'} | "
                         f"{len(mine) - len(better) - len(worse)} | {lost} / {base_lost} |")
    return "\n".join(lines)


def is_baseline_row(row: dict, baseline: str | None) -> bool:
    """Whether ``row`` is the baseline's own: its resolved spec (``policy_spec``; a row
    without one, its name) is ``baseline``, the resolved spec compared with. A model's rows
    are named shorter than its spec (``ppo:x`` for ``ppo:runs/x/model.zip``)."""
    return baseline is not None and row.get("policy_spec", row.get("policy")) == baseline


def _difference_cell(row: dict, baseline: str) -> str:
    if is_baseline_row(row, baseline) or "rms_position_settled_diff_mean" not in row:
        return "—"
    key = "rms_position_settled"
    base_mean = row[f"{key}_mean"] - row[f"{key}_diff_mean"]
    relative = row[f"{key}_diff_mean"] / base_mean if base_mean > 0 else float("nan")
    if _one_flight(row):
        return (f"{relative:+.0%}: {row[f'{key}_diff_mean']:+.4f} (one flight each way: "
                "no interval)")
    mark = "" if (row[f"{key}_diff_low"] > 0 or row[f"{key}_diff_high"] < 0) else " (n.s.)"
    return (f"{relative:+.0%}: {row[f'{key}_diff_mean']:+.4f} "
            f"[{row[f'{key}_diff_low']:+.4f}, {row[f'{key}_diff_high']:+.4f}]{mark}")


def main(policies: list[str], scenarios: list[str], seeds: str, out: Path,
         as_json: bool, baseline: str | None = None, suite: bool = False, *,
         trust_pickle: bool = False, scenario_options: dict[str, object] | None = None,
         delay_grid: Sequence[float] | None = None, merge: Sequence[Path] = (),
         command: list[str] | None = None, delay_path: str | None = None,
         env_id: str | None = None) -> int:
    """``baseline`` None: the recommended base; "": no comparison. ``suite``: every
    scenario of the benchmark's suite (``SUITES``, by ``scenario_options["benchmark"]``,
    v1, the library's default, when not given; the CLI gives ``TOOLS_BENCHMARK``) instead
    of ``scenarios``, and ``leaderboard.md``.
    ``trust_pickle`` (``--trust-pickle``): model files may be unpickled.
    ``scenario_options`` (``--scenario-option KEY=VALUE``): passed to every scenario.
    ``delay_grid`` (``--delay-margins``): the latencies each delay margin is searched on;
    ``delay_path`` (``--delay-on``): where they are added (None: the benchmark's margin's).
    ``merge`` (``--merge``): other runs' ``evaluation.json`` files, merged with this one's
    into ``leaderboard-merged.md`` (``evaluation.results``); ``command`` is recorded
    in ``evaluation.json``. ``env_id`` (``--env``): the id model zips saved without a
    training config (by SB3 or rl-zoo3) were trained on."""
    others = [(path, read_document(path)) for path in merge]  # a bad file fails first
    baseline = DEFAULT_BASE_CONTROLLER if baseline is None else baseline
    benchmark = str((scenario_options or {}).get("benchmark", LIBRARY_BENCHMARK))
    if suite:
        if benchmark not in SUITES:
            raise ValueError(f"--suite: no suite for benchmark {benchmark!r}; there are "
                             + ", ".join(SUITES))
        scenarios = [name for names in SUITES[benchmark].values() for name in names]
    seed_list = parse_seeds(seeds)
    first_flights: dict = {}
    policy_list = list(dict.fromkeys(policies))
    # the first line at once: what will be flown, before the policies load
    print(f"evaluate: {len(policy_list)} policies x {len(scenarios)} scenarios x "
          f"{len(seed_list)} seeds, Benchmark {benchmark}"
          + ("" if as_json else f", into {out}"), file=sys.stderr, flush=True)
    rows = evaluate(policies, scenarios, seed_list, first_flights, baseline or None,
                    trust_pickle=trust_pickle, scenario_options=scenario_options,
                    delay_grid=delay_grid, delay_path=delay_path, env_id=env_id,
                    progress=True)
    if as_json:
        print(json.dumps(rows, indent=1))
        return 0
    # a shipped residual in the comparison: say which of them this benchmark calls for
    advice = ([shipped_policy_advice(benchmark, rows)]
              if any(spec.startswith("residual") and resolve_spec(spec, benchmark)
                     in (f"residual:{name}" for name in SHIPPED_TRAINED_IN) for spec in policies)
              else [])
    print(f"evaluate: writing the tables, the bar plot and report.html into {out}",
          file=sys.stderr, flush=True)
    write_tables(rows, out, advice)
    document = results_document(rows, seed_list, scenario_options or {}, command)
    write_document(document, out / "evaluation.json")
    columns = [("scenario", "scenario"), ("policy", "policy"), ("seeds", "seeds")]
    for key, label in SCORES:
        columns += [(f"{key}_mean", f"{label} mean"), (f"{key}_std", "± std")]
    compared_with = resolve_spec(baseline, benchmark) if baseline else None
    if compared_with:
        columns += [("rms_position_settled_diff_mean", f"Δ RMS ‖e_x‖ vs {compared_with} [m]"),
                    ("rms_position_settled_diff_low", "95 % CI low"),
                    ("rms_position_settled_diff_high", "high")]
    write_report(out / "report.html", f"quad-dob evaluate (figures: seed {seed_list[0]})",
                 rows, [*columns, ("crash_rate", "crash rate")], first_flights,
                 baseline=compared_with,
                 notes=advice)
    if others:
        labels = source_labels([out / "evaluation.json", *(path for path, _ in others)])
        merged = merged_leaderboard(list(zip(labels, [document, *(d for _, d in others)],
                                             strict=True)))
        (out / "leaderboard-merged.md").write_text(merged)
    print(evaluation_table(rows, compared_with))
    if suite:
        (out / "leaderboard.md").write_text(leaderboard(rows, benchmark) + "\n")
        print("\n" + ranking_lines(rows))
    for paragraph in advice:
        print("\n" + "\n".join(textwrap.fill(line, WIDTH, break_on_hyphens=False)
                                for line in paragraph.splitlines()))
    written = [*(["leaderboard.md"] if suite else []),
               *(["leaderboard-merged.md"] if others else []), "evaluation.md",
               "evaluation.json", "evaluation.csv", "evaluation.png", "report.html"]
    print("\n" + textwrap.fill(f"wrote into {out}/: " + ", ".join(written), WIDTH,
                               break_on_hyphens=False, break_long_words=False))
    return 0
