"""The wind-tunnel tables of docs/benchmark-v2.md from ``quad-dob evaluate`` runs on
``figure8-wind-*``.

Run by hand after the evaluations that page names: ``<folder>/v2`` (Benchmark v2's loop)
and one folder per factor switched off (``VARIANTS``), then
``python benchmarks/wind_tunnel_table.py <folder>``. Prints the simulated counterparts
beside Neural-Fly's real flights (``quad_dob_training.wind_tunnel``), then the ablation:
each counterpart's RMS error per wind speed with each factor of parts 1 and 2 off in turn.
"""

from __future__ import annotations

from variants import variant_rows

from quad_dob_training.wind_tunnel.published import (
    COUNTERPARTS,
    WIND_SPEEDS,
    rms_by_wind,
    side_by_side,
)

# folder name -> what it flies: Benchmark v2, then each factor of parts 1 and 2 off in turn
VARIANTS = {
    "v2": "Benchmark v2",
    "no-sensing": "ideal sensing (mocap off)",
    "no-inner": "no inner loop",
    "no-speed-motors": "thrust-lag motors",
    "no-thrust-uncertainty": "no thrust uncertainty",
    "no-rotor-aerodynamics": "no rotor aerodynamics",
    "v1": "all five off (v1's loop, v2's gains)",
}


def main() -> None:
    rows = variant_rows(__doc__.splitlines()[0], VARIANTS)
    print(side_by_side(rows["v2"], "Benchmark v2") + "\n")
    print("Ablation: RMS ‖e_x‖ after 5 s [mm], mean of the seeds; flights lost in brackets\n")
    header = "| loop | " + " | ".join(f"{policy} {speed}" for policy in COUNTERPARTS
                                      for speed in WIND_SPEEDS) + " |"
    print(header)
    print("|---|" + "---|" * (len(COUNTERPARTS) * len(WIND_SPEEDS)))
    for name, flown in rows.items():
        lost = {(row["scenario"], row["policy"]): int(row["crashes"]) for row in flown}
        cells = []
        for policy in COUNTERPARTS:
            for speed, value in zip(WIND_SPEEDS, rms_by_wind(flown, policy), strict=True):
                crashed = lost.get((f"figure8-wind-{speed}", policy), 0)
                cells.append("—" if value is None else f"{1000 * value:.1f}"
                             + (f" ({crashed})" if crashed else ""))
        print(f"| {VARIANTS[name]} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
