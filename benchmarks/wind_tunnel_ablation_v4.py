"""Benchmark v4's ablation on the wind tunnel: each v4 mechanism off in turn (back to v3's),
and each ranged value at both ends of its source's range (``benchmark_v4.ABLATION_ENDS``),
with v3's gain sets fixed; every shape statistic's change with its paired 95 % interval.

``python benchmarks/wind_tunnel_ablation_v4.py [--seeds 9701-9720] [--variants a,b]
[--json PATH]`` flies the four counterparts of Neural-Fly's controllers on the four
figure-8s once per variant, as ``quad-dob wind-tunnel --benchmark v4`` flies them (50 s,
the logs' span), scores each flight with ``flight_statistics`` over its first
``LAPS`` whole laps after 5 s, and prints per counterpart and wind: v4's value of each
statistic, then for each variant the mean of v4 - variant over the seeds both kept, with
its 95 % interval (Student's t on the paired differences; a phase's difference wrapped to
±180°), and the flights each lost. A mechanism whose interval excludes 0 moves that
statistic. Seeds 9701-9720 are v4's report seeds (docs/benchmark-v4.md). The counterparts
are part 1's, today's controllers at v3's gains (``wind_tunnel.COUNTERPARTS``), as the
issue asks of part 1: v4's own sets of those names (issue 55's search) are set aside while
they fly (``v3_gains``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import sys
from collections.abc import Iterator
from typing import Any

import numpy as np

from quad_dob_baselines import BENCHMARK_INPUTS, GAIN_SETS
from quad_dob_env.benchmark import v3_loop
from quad_dob_env.benchmark_v3 import REAL_LOOPS
from quad_dob_env.benchmark_v4 import ABLATION_ENDS, V4_LOOPS
from quad_dob_env.params import get_vehicle
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.wind_tunnel.ablation import ablation_arguments, chosen_variants
from quad_dob_training.wind_tunnel.published import COUNTERPARTS, WIND_SPEEDS
from quad_dob_training.wind_tunnel.tool import simulate

VEHICLE = "neural-fly"  # the figure-8s' vehicle
DURATION = 50.0  # [s] about the logs' span
LAPS = 5  # whole laps after 5 s every variant flies in 50 s (the ramp's first lap is slow)
# the shape statistics compared, by flight_statistics' flat names, and how each is shown
STATISTICS = {
    "rms_total": ("RMS [mm]", 1000.0), "rms.x": ("RMS x [mm]", 1000.0),
    "rms.z": ("RMS z [mm]", 1000.0), "mean.x": ("mean x [mm]", 1000.0),
    "mean.z": ("mean z [mm]", 1000.0), "z_share": ("z share", 1.0),
    "harmonics.2.z": ("z at 2/lap [mm]", 1000.0),
    "harmonics.2.phase.z": ("its phase [°]", 180.0 / math.pi),
    "lap_periodic_share": ("lap-periodic share", 1.0), "mean_fa_x": ("mean fa_x [N]", 1.0),
    "command_over_hover_mean": ("command/hover", 1.0),
    "command_over_hover_peak": ("its peak", 1.0), "limit_share": ("at a limit", 1.0),
}
# Student's t, 97.5 %, by degrees of freedom (1-30); beyond, the normal's 1.96
T975 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
        2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
        2.060, 2.056, 2.052, 2.048, 2.045, 2.042)


def variants() -> dict[str, tuple[dict[str, Any], dict[str, Any] | None]]:
    """Variant label -> (the scenario options that fly it, INDI's inputs in it; None: v4's)."""
    vehicle, v4 = get_vehicle(VEHICLE), V4_LOOPS[VEHICLE]

    def thrust_model(factor: float) -> Any:
        return dataclasses.replace(v4.throttle_map, thrust_model_factor=factor)

    def tones(level: float) -> Any:
        return dataclasses.replace(v4.vibration, rotor_level=level, blade_pass_level=level)

    found: dict[str, tuple[dict[str, Any], dict[str, Any] | None]] = {"Benchmark v4": ({}, None)}
    found["estimators told the rotors' output (v3's)"] = ({"estimator_wrench": "applied"}, None)
    found["INDI on rotor telemetry (v3's)"] = ({}, {})
    found["drag v3's"] = ({"airframe_drag": False}, None)
    found["vibration white (v3's)"] = ({"imu_vibration_tones": False,
                                        "imu_vibration": v3_loop(vehicle, "ablation")[
                                            "imu_vibration"]}, None)
    for end in ABLATION_ENDS["vibration.level"]:
        found[f"tones {end:g} m/s²"] = ({"imu_vibration_tones": tones(end)}, None)
    found["throttle κ 0.4 (v3's)"] = (
        {"throttle_map": REAL_LOOPS[VEHICLE].throttle_map}, None)
    for end in ABLATION_ENDS["throttle_map.thrust_model_factor"]:
        found[f"throttle κ {end:g}"] = ({"throttle_map": thrust_model(end)}, None)
    found["reference at speed from the start (v3's)"] = ({"reference_ramp": 0.0}, None)
    return found


@contextlib.contextmanager
def v3_gains() -> Iterator[None]:
    """The counterparts fly v3's sets in v4 (``gain_sets.INHERITED_FROM``) while inside:
    their v4 sets are set aside, and restored after."""
    aside = {key: GAIN_SETS.pop(key) for key in list(GAIN_SETS)
             if key[0] in COUNTERPARTS and key[1] == "v4"}
    try:
        yield
    finally:
        GAIN_SETS.update(aside)


@contextlib.contextmanager
def indi_inputs(inputs: dict[str, Any] | None) -> Iterator[None]:
    """INDI's v4 inputs replaced by ``inputs`` while flying (None: v4's own)."""
    if inputs is None:
        yield
        return
    key = ("indi", "v4")
    kept = BENCHMARK_INPUTS[key]
    BENCHMARK_INPUTS[key] = inputs
    try:
        yield
    finally:
        BENCHMARK_INPUTS[key] = kept


def paired(base: dict[int, float], other: dict[int, float], phase: bool
           ) -> tuple[float, float, int] | None:
    """Mean of base - other over the seeds both hold, its 95 % half-width, and the count."""
    seeds = sorted(set(base) & set(other))
    if len(seeds) < 2:
        return None
    differences = np.array([base[s] - other[s] for s in seeds])
    if phase:
        differences = (differences + math.pi) % (2 * math.pi) - math.pi
    half = T975[min(len(seeds) - 1, len(T975)) - 1] * differences.std(ddof=1) / math.sqrt(
        len(seeds))
    return float(differences.mean()), float(half), len(seeds)


def per_seed(rows: list[dict[str, Any]]) -> dict[tuple[str, float], dict[str, dict[int, float]]]:
    """(counterpart, wind) -> statistic -> seed -> value over ``LAPS`` laps."""
    found = {}
    for row in rows:
        values = row["per_seed"].get(str(LAPS), [])
        found[(row["policy"], row["wind_speed"])] = {
            name: {seed: flat[name] for seed, flat in zip(row["scored_seeds"], values,
                                                           strict=True)}
            for name in STATISTICS}
        found[(row["policy"], row["wind_speed"])]["lost"] = row["crashes"]
    return found


def main() -> None:
    args = ablation_arguments(__doc__.splitlines()[0], "9701-9720")
    table = variants()
    wanted = chosen_variants(args, table)
    if not wanted:
        return
    if "Benchmark v4" not in wanted:
        wanted.insert(0, "Benchmark v4")
    seeds = parse_seeds(args.seeds)
    print(f"wind_tunnel_ablation_v4: {len(wanted)} variants x {len(COUNTERPARTS)} controllers x "
          f"{len(WIND_SPEEDS)} winds x {len(seeds)} seeds", file=sys.stderr, flush=True)
    flown = {}
    for number, label in enumerate(wanted, 1):
        # each variant's flights report themselves (a controller in a wind a line)
        print(f"wind_tunnel_ablation_v4: variant {number}/{len(wanted)} {label}",
              file=sys.stderr, flush=True)
        options, inputs = table[label]
        with indi_inputs(inputs), v3_gains():
            flown[label] = per_seed(simulate("v4", seeds, DURATION, {LAPS}, options,
                                             COUNTERPARTS, progress=True))
        print(f"flown: {label}", flush=True)
    base = flown["Benchmark v4"]
    document: dict[str, Any] = {}
    print(f"\nBenchmark v4's ablation, seeds {args.seeds}, {LAPS} whole laps after 5 s: v4's "
          "value (mean over the seeds kept), then v4 - variant, mean [95 % interval] over the "
          "seeds both kept; flights lost in brackets where any")
    for policy in COUNTERPARTS:
        for wind in WIND_SPEEDS:
            cell = (policy, float(wind))
            print(f"\n### {policy}, {wind} m/s (v4 lost {base[cell]['lost']})\n")
            labels = [label for label in wanted if label != "Benchmark v4"]
            print("| statistic | v4 | " + " | ".join(labels) + " |")
            print("|---|---|" + "---|" * len(labels))
            for name, (shown, scale) in STATISTICS.items():
                values = list(base[cell][name].values())
                phase = ".phase." in name
                mean = (math.atan2(np.mean(np.sin(values)), np.mean(np.cos(values))) if phase
                        else float(np.mean(values))) if values else float("nan")
                cells = []
                for label in labels:
                    change = paired(base[cell][name], flown[label][cell][name], phase)
                    lost = flown[label][cell]["lost"]
                    text = ("—" if change is None else
                            f"{scale * change[0]:+.3g} [{scale * (change[0] - change[1]):+.3g},"
                            f" {scale * (change[0] + change[1]):+.3g}]")
                    cells.append(text + (f" ({lost})" if lost else ""))
                    document.setdefault(label, {}).setdefault(f"{policy}|{wind}", {})[name] = (
                        None if change is None else {"mean": change[0], "half_width": change[1],
                                                     "seeds": change[2], "lost": lost})
                print(f"| {shown} | {scale * mean:.3g} | " + " | ".join(cells) + " |")
    if args.json:
        args.json.write_text(json.dumps(document, indent=1) + "\n")


if __name__ == "__main__":
    main()
