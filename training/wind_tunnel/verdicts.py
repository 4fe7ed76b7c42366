"""A simulated counterpart against its real run, statistic by statistic: a verdict where
Benchmark v4's targets give a tolerance (issue 54, part 1: force and headroom; issue 55,
part 2: RMS, the calm z share, the offsets), the ratio sim / real elsewhere (a phase: the
difference). Both sides' statistics come from ``flight_statistics`` over the same whole
laps, as ``tool.flat`` names them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

RELATIVE, ABSOLUTE, FACTOR, BELOW, OFFSET = "relative", "absolute", "factor", "below", "offset"


@dataclass(frozen=True)
class Tolerance:
    """How close a simulated statistic must come to the real one, and where that holds.

    ``kind``: ``relative`` |sim / real - 1| <= bound; ``absolute`` |sim - real| <= bound;
    ``factor`` 1 / bound <= sim / real <= bound; ``below`` sim < bound (the simulation's
    own target; the real value is shown beside it); ``offset`` the same sign as the real and
    0.5-2x it where |real| exceeds ``bound``, else |sim| < bound. ``winds`` [m/s]: the
    tunnel speeds it is a target at (None: every one)."""

    statistic: str
    label: str
    kind: str
    bound: float
    scale: float  # to the unit shown
    unit: str
    target: str  # where the target is written
    winds: tuple[float, ...] | None = None


TOLERANCES = (
    Tolerance("mean_fa_x", "mean fa_x", RELATIVE, 0.15, 1.0, "N",
              "v4 part 1: force", (4.2, 8.5, 12.1)),
    Tolerance("command_over_hover_mean", "command / hover, mean", ABSOLUTE, 0.10, 1.0, "",
              "v4 part 1: headroom", (12.1,)),
    Tolerance("command_over_hover_peak", "command / hover, peak", ABSOLUTE, 0.15, 1.0, "",
              "v4 part 1: headroom", (12.1,)),
    Tolerance("limit_share", "at a limit", BELOW, 0.02, 100.0, "%",
              "v4 part 1: headroom", (12.1,)),
    Tolerance("rms_total", "RMS", FACTOR, 1.5, 1e3, "mm", "v4 part 2: RMS"),
    Tolerance("z_share", "z share", ABSOLUTE, 0.15, 1.0, "", "v4 part 2: calm z share",
              (0.0,)),
    Tolerance("mean.x", "mean x", OFFSET, 0.050, 1e3, "mm", "v4 part 2: offsets", (12.1,)),
    Tolerance("mean.z", "mean z", ABSOLUTE, 0.030, 1e3, "mm", "v4 part 2: offsets", (12.1,)),
)
# the shape statistics without a target, (name, label, scale to the unit shown, unit):
# their ratio, sim / real (a phase: sim - real)
RATIOS = (("rms.x", "RMS x", 1e3, "mm"), ("rms.y", "RMS y", 1e3, "mm"),
          ("rms.z", "RMS z", 1e3, "mm"), ("harmonics.1.z", "z at 1 rad/s", 1e3, "mm"),
          ("harmonics.2.z", "z at 2 rad/s", 1e3, "mm"),
          ("harmonics.2.phase.z", "z phase at 2 rad/s", 180 / math.pi, "°"),
          ("lap_periodic_share", "lap-periodic share", 1.0, ""))


def _finite(*values: float | None) -> bool:
    return all(value is not None and math.isfinite(value) for value in values)


def within(tolerance: Tolerance, real: float, simulated: float) -> bool:
    """Whether ``simulated`` meets ``tolerance`` against ``real``."""
    bound, kind = tolerance.bound, tolerance.kind
    if kind == RELATIVE:
        return abs(simulated / real - 1.0) <= bound
    if kind == ABSOLUTE:
        return abs(simulated - real) <= bound
    if kind == FACTOR:
        return 1.0 / bound <= simulated / real <= bound
    if kind == BELOW:
        return simulated < bound
    if kind == OFFSET:
        if abs(real) > bound:
            return simulated * real > 0 and 0.5 <= simulated / real <= 2.0
        return abs(simulated) < bound
    raise ValueError(f"unknown tolerance kind {kind!r}; known: {RELATIVE}, {ABSOLUTE}, "
                     f"{FACTOR}, {BELOW}, {OFFSET}")


def describe(tolerance: Tolerance) -> str:
    """The tolerance in words, with its unit."""
    bound = tolerance.bound * tolerance.scale
    unit = f" {tolerance.unit}" if tolerance.unit else ""
    return {RELATIVE: f"within {tolerance.bound:.0%} of the real",
            ABSOLUTE: f"within ±{bound:g}{unit} of the real",
            FACTOR: f"within {tolerance.bound:g}x of the real",
            BELOW: f"below {bound:g}{unit}",
            OFFSET: f"same sign, 0.5-2x where |real| > {bound:g}{unit}, else under "
                    f"{bound:g}{unit}"}[tolerance.kind]


def verdicts(real: dict[str, float], simulated: dict[str, float], wind_speed: float | None
             ) -> list[dict[str, object]]:
    """Each statistic's row: the real and simulated values (in their shown unit) and the
    verdict, ``within``/``outside`` with the tolerance beside it where a target applies at
    this wind, else the ratio sim / real (a phase: the difference in degrees)."""
    rows: list[dict[str, object]] = []
    for tolerance in TOLERANCES:
        if tolerance.winds is not None and wind_speed not in tolerance.winds:
            continue
        r, s = real.get(tolerance.statistic), simulated.get(tolerance.statistic)
        verdict = "—"
        if _finite(r, s) and (tolerance.kind == BELOW or r != 0):
            verdict = (f"{'within' if within(tolerance, r, s) else 'outside'}: "
                       f"{describe(tolerance)} ({tolerance.target})")
        rows.append({"statistic": tolerance.label, "unit": tolerance.unit,
                     "real": None if r is None else r * tolerance.scale,
                     "simulated": None if s is None else s * tolerance.scale,
                     "verdict": verdict})
    for statistic, label, scale, unit in RATIOS:
        r, s = real.get(statistic), simulated.get(statistic)
        verdict = "—"
        if _finite(r, s) and ".phase." in statistic:
            difference = (s - r + math.pi) % (2 * math.pi) - math.pi
            verdict = f"sim - real {math.degrees(difference):+.0f}°"
        elif _finite(r, s) and r != 0:
            verdict = f"sim / real {s / r:.2f}"
        rows.append({"statistic": label, "unit": unit,
                     "real": None if r is None else r * scale,
                     "simulated": None if s is None else s * scale, "verdict": verdict})
    return rows
