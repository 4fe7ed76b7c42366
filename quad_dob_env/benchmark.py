"""Benchmark v1 or v2, as one scenario option (``Scenario.benchmark``).

``"v1"`` is the loop v1 measured: ideal sensing, one controller at the control rate, a lag
on the thrust, no rotor aerodynamics. ``"v2"`` is the loop a real vehicle flies, parts 1
and 2 of Benchmark v2 together: ``mocap`` sensing, the inner loop at ``V2_INNER_RATE``
(the smallest multiple of the control rate at or above it), motors on rotor speed, thrust
uncertainty and rotor aerodynamics (with the drag they act through). A loop field given
with the scenario (``sensing="ideal"``, ``speed_motors=False``, ``inner_rate=0``, ...)
keeps its value under either benchmark: that is how one factor is switched off in turn.
Imports nothing above ``validation``.
"""

from __future__ import annotations

import math
from typing import Any

from quad_dob_env.validation import unknown_name_error

BENCHMARKS = ("v1", "v2")
# Benchmark v2's inner loop [Hz]: PX4's attitude loop rate (IMU_INTEG_RATE, 200 Hz by
# default; its rate loop runs at IMU_GYRO_RATEMAX, 400 Hz), over the 100 Hz position loop
# of dt = 0.01 s. There the full v2 loop with the base at N = 1024 keeps 0.38-0.43 of v1's
# throughput, above the third asked for; at 400 Hz 0.28-0.32 (docs/benchmark-v2-loop.md,
# "Speed of the vehicle loop").
V2_INNER_RATE = 200.0
V2_SENSING = "mocap"
# the fields a benchmark sets where the scenario leaves them None
LOOP_FIELDS = ("sensing", "inner_rate", "speed_motors", "thrust_uncertainty",
               "rotor_aerodynamics", "drag")


def v2_inner_rate(dt: float) -> float:
    """The smallest whole multiple of 1/dt at or above ``V2_INNER_RATE``."""
    return math.ceil(V2_INNER_RATE * dt - 1e-9) / dt


def loop_fields(benchmark: Any, given: dict[str, Any], dt: float, actuation: str,
                name: str) -> dict[str, Any]:
    """The loop fields of a scenario flown under ``benchmark``: those ``given`` (not None)
    as they are, the rest the benchmark's; ``inner_rate`` 0 means none."""
    if benchmark not in BENCHMARKS:
        raise unknown_name_error("benchmark", benchmark, BENCHMARKS)
    v2 = benchmark == "v2"
    if v2 and actuation != "rotors":
        raise ValueError(f"benchmark='v2' flies rotors (speed motors, rotor aerodynamics), but "
                         f"scenario {name!r} flies actuation={actuation!r}, the paper's "
                         "wrench: the paper-* scenarios are v1-only (benchmark='v1')")
    defaults = {"sensing": V2_SENSING if v2 else None,
                "inner_rate": v2_inner_rate(dt) if v2 else None,
                "speed_motors": v2, "thrust_uncertainty": v2, "rotor_aerodynamics": v2,
                # the air-relative velocity the rotors' aerodynamics act on
                "drag": v2}
    resolved = {key: defaults[key] if given[key] is None else given[key]
                for key in LOOP_FIELDS}
    if given["rotor_aerodynamics"] is None and given["drag"] is not None:
        # drag switched off by hand takes the rotors' aerodynamics (which act through the
        # air-relative velocity it turns on) with it
        resolved["rotor_aerodynamics"] = resolved["rotor_aerodynamics"] and bool(given["drag"])
    if isinstance(resolved["inner_rate"], (int, float)) and resolved["inner_rate"] == 0:
        resolved["inner_rate"] = None
    return resolved


def scenario_options_for(options: dict[str, Any] | None, benchmark: str | None
                         ) -> dict[str, Any]:
    """``options`` for ``make_scenario`` with ``benchmark`` beneath them (what an env's
    ``benchmark=`` keyword, the ``-v2`` ids', adds: an option given wins)."""
    return {**({} if benchmark is None else {"benchmark": benchmark}), **(options or {})}

