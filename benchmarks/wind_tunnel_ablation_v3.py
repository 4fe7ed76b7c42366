"""Benchmark v3's ablation on the wind tunnel: each v3 factor off in turn, and each ranged
value at both ends of its source's range (``benchmark_v3.ABLATION_ENDS``), with v3's gain
sets fixed.

``python benchmarks/wind_tunnel_ablation_v3.py [--seeds 9001-9020] [--variants a,b]``
flies the four counterparts of Neural-Fly's controllers (``wind_tunnel.COUNTERPARTS``) on
the four figure-8s once per variant, as ``quad-dob wind-tunnel`` flies them, and prints per
variant the RMS ‖e_x‖ after 5 s [mm] (mean of the flights kept; flights lost in brackets) and the
calm figure-8's z share of the squared error. Seeds 9001-9020 are the tunnel's evaluation
seeds: no gain was tuned on them. The D-term low-pass is not in the ablation: v3 does not
model it (docs/benchmark-v3.md, "Not modelled").
"""

from __future__ import annotations

import dataclasses
import json
import sys
from typing import Any

import numpy as np

from quad_dob_env.benchmark import V3_LOOP_FIELDS, v3_loop
from quad_dob_env.benchmark_v3 import ABLATION_ENDS, REAL_LOOPS
from quad_dob_env.params import get_vehicle
from quad_dob_env.sensing.models import SENSING_PRESETS
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.wind_tunnel.ablation import ablation_arguments, chosen_variants
from quad_dob_training.wind_tunnel.published import COUNTERPARTS, WIND_SPEEDS
from quad_dob_training.wind_tunnel.tool import simulate

VEHICLE = "neural-fly"  # the figure-8s' vehicle


def variants() -> dict[str, dict[str, Any]]:
    """Variant label -> the scenario options that fly it (v3 otherwise)."""
    real, vehicle = REAL_LOOPS[VEHICLE], get_vehicle(VEHICLE)
    tau = real.motor_time_constants
    mocap = SENSING_PRESETS["mocap"]
    gyro_vibration, accelerometer_vibration = v3_loop(vehicle, "ablation")["imu_vibration"]

    def pose_latency(latency: float) -> Any:
        return dataclasses.replace(mocap, pose=dataclasses.replace(mocap.pose, latency=latency))

    def thrust_model(factor: float) -> Any:
        return dataclasses.replace(real.throttle_map, thrust_model_factor=factor)

    def vibration(raw: float) -> tuple[float, float]:
        return (gyro_vibration, accelerometer_vibration * raw / real.accelerometer_vibration)

    ends = ABLATION_ENDS
    found: dict[str, dict[str, Any]] = {"Benchmark v3": {}}
    found["v3's motors off (v2's time constant)"] = {"motor_time_constants": False}
    for end in ends["motor_time_constants.up"]:
        found[f"motors up {1000 * end:g} ms"] = {"motor_time_constants": (end, tau[1])}
    for end in ends["motor_time_constants.down"]:
        found[f"motors down {1000 * end:g} ms"] = {"motor_time_constants": (tau[0], end)}
    found["gyro low-pass off"] = {"gyro_cutoff": 0}
    for end in ends["pose_latency"]:
        found[f"pose latency {1000 * end:g} ms"] = {"sensing": pose_latency(end)}
    found["pose latency on the control grid (v2's)"] = {"pose_latency_on_ticks": False}
    found["throttle map off (thrust as believed)"] = {"throttle_map": False}
    for end in ends["throttle_map.thrust_model_factor"]:
        found[f"thrust model κ {end:g}"] = {"throttle_map": thrust_model(end)}
    found["vibration off"] = {"imu_vibration": False}
    for end in ends["accelerometer_vibration"]:
        if end:  # 0 is "vibration off"
            found[f"vibration {end:g} m/s²"] = {"imu_vibration": vibration(end)}
    found["model tolerance off (exact model)"] = {"model_tolerance": False}
    for end in ends["tunnel_turbulence_intensity"]:
        found[f"turbulence {100 * end:g} %"] = {"turbulence_intensity": end}
    # every field v3 sets beyond v2's loop, off (False: benchmark.loop_fields' "off")
    found["all v3 factors off (v2's loop at 50 Hz with v3's gains)"] = dict.fromkeys(
        V3_LOOP_FIELDS, False)
    return found


def cells(rows: list[dict[str, Any]], seeds: list[int]) -> list[str]:
    """RMS after 5 s [mm] per counterpart and wind, the mean over the flights kept, and the
    flights lost in brackets ("—": every flight lost)."""
    by = {(row["policy"], row["scenario"]): row for row in rows}
    out = []
    for policy in COUNTERPARTS:
        for speed in WIND_SPEEDS:
            row = by[(policy, f"figure8-wind-{speed}")]
            kept = [rms for seed, rms in zip(seeds, row["rms_after_skip"], strict=True)
                    if seed in row["scored_seeds"]]
            lost = f" ({row['crashes']})" if row["crashes"] else ""
            out.append(("—" if not kept else f"{1000 * np.mean(kept):.1f}") + lost)
    return out


def calm_z_share(rows: list[dict[str, Any]]) -> list[str]:
    """The calm figure-8's z share of the squared error per counterpart, over its laps."""
    by = {(row["policy"], row["scenario"]): row for row in rows}
    out = []
    for policy in COUNTERPARTS:
        means = by[(policy, "figure8-wind-0")]["mean"]
        own = str(by[(policy, "figure8-wind-0")]["laps"])
        out.append(f"{means[own]['z_share']:.2f}" if own in means else "—")
    return out


def main() -> None:
    args = ablation_arguments(__doc__.splitlines()[0], "9001-9020")
    table = variants()
    wanted = chosen_variants(args, table)
    if not wanted:
        return
    seeds = parse_seeds(args.seeds)
    print(f"wind_tunnel_ablation_v3: {len(wanted)} variants x {len(COUNTERPARTS)} controllers x "
          f"{len(WIND_SPEEDS)} winds x {len(seeds)} seeds", file=sys.stderr, flush=True)
    flown = {}
    for number, label in enumerate(wanted, 1):
        # each variant's flights report themselves (a controller in a wind a line)
        print(f"wind_tunnel_ablation_v3: variant {number}/{len(wanted)} {label}",
              file=sys.stderr, flush=True)
        flown[label] = simulate("v3", seeds, None, set(), table[label], progress=True)
    print(f"Benchmark v3's ablation, seeds {args.seeds}: RMS ‖e_x‖ after 5 s [mm], mean of "
          "the flights kept; flights lost in brackets. The calm z share is z's share of the "
          "squared error at 0 m/s, pooled over the seeds")
    names = list(COUNTERPARTS)
    scored = {label: (cells(rows, seeds), calm_z_share(rows)) for label, rows in flown.items()}
    for pair in (names[:2], names[2:]):
        print("\n| variant | " + " | ".join(f"{policy} {speed}" for policy in pair
                                          for speed in WIND_SPEEDS) + " | calm z share |")
        print("|---|" + "---|" * (len(pair) * len(WIND_SPEEDS) + 1))
        for label, (found, shares) in scored.items():
            columns = [found[names.index(p) * len(WIND_SPEEDS) + k] for p in pair
                       for k in range(len(WIND_SPEEDS))]
            share = ", ".join(shares[names.index(p)] for p in pair)
            print(f"| {label} | " + " | ".join(columns) + f" | {share} |")
    if args.json:
        args.json.write_text(json.dumps(
            {label: [{key: row[key] for key in ("policy", "scenario", "crashes", "scored_seeds",
                                                "rms_after_skip")} for row in rows]
             for label, rows in flown.items()}, indent=1))


if __name__ == "__main__":
    main()
