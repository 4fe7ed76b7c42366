"""The vehicle-loop table of docs/benchmark-v2-loop.md from ``quad-dob evaluate`` runs, one
per factor of Benchmark v2 part 2 (each on alone, the rest as v1), plus the full loop.

Run by hand after the evaluations that page names (``results/loop/<variant>``, variants
below), then ``python benchmarks/loop_table.py results/loop``. Prints, per scenario, each
policy's RMS position error (t >= 2 s) with its 95 % bootstrap interval and the flights it
lost under each variant.
"""

from __future__ import annotations

from variants import variant_rows

# folder name -> column title; the first is the reference every factor is read against
VARIANTS = {
    "v1": "v1",
    "inner": "inner loop 200 Hz",
    "speed": "speed motors",
    "thrust": "thrust uncertainty",
    "aero": "rotor aerodynamics",
    "full": "all four + mocap",
}


def main() -> None:
    rows = variant_rows(__doc__.splitlines()[0], VARIANTS)
    reference = rows["v1"]
    scenarios = list(dict.fromkeys(row["scenario"] for row in reference))
    for scenario in scenarios:
        print(f"**{scenario}**: RMS ‖e_x‖ after 2 s [mm], mean [95 % CI]; flights lost of "
              "20\n")
        print("| policy | " + " | ".join(VARIANTS[name] for name in rows) + " |")
        print("|---|" + "---|" * len(rows))
        for policy in [row["policy"] for row in reference if row["scenario"] == scenario]:
            cells = []
            for variant in rows.values():
                row = next(r for r in variant
                           if r["scenario"] == scenario and r["policy"] == policy)
                lost = int(row["crashes"])
                cells.append(f"{1e3 * float(row['rms_position_settled_mean']):.1f} "
                             f"[{1e3 * float(row['rms_position_settled_low']):.1f}, "
                             f"{1e3 * float(row['rms_position_settled_high']):.1f}]"
                             + (f", **{lost} lost**" if lost else ""))
            print(f"| {policy} | " + " | ".join(cells) + " |")
        print()


if __name__ == "__main__":
    main()
