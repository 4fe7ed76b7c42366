"""Benchmark v1, v2, v3 or v4, as one option of the vehicle loop (``LoopOptions.benchmark``).

``"v1"`` is the loop v1 measured: ideal sensing, one controller at the control rate, a lag
on the thrust, no rotor aerodynamics. ``"v2"`` is the loop a real vehicle flies, parts 1
and 2 of Benchmark v2 together: ``mocap`` sensing, the inner loop at ``V2_INNER_RATE``
(the smallest multiple of the control rate at or above it), motors on rotor speed, thrust
uncertainty and rotor aerodynamics (with the drag they act through). ``"v3"`` is v2's loop
with the real vehicle's lag and thrust path (``quad_dob_env.benchmark_v3``, every value
sourced): the motors' measured time constants, the autopilot's gyro low-pass and the pose
latency on the inner loop's tick grid, the throttle map with the battery under it in place
of thrust uncertainty, vibration on the IMU and the controllers' model off the truth.
``"v4"`` is v3's loop with five mechanisms corrected against Neural-Fly's logs
(``quad_dob_env.benchmark_v4``): the estimators told the autopilot's command, the drag
fitted in the simulator's tilted equilibrium, the vibration as tones in place of v3's white
noise, the identified throttle curve (and, outside the loop, INDI's actuator model and the
tunnel's reference from rest).

A loop field given with the scenario (``sensing="ideal"``, ``speed_motors=False``,
``inner_rate=0``, ...) keeps its value under any benchmark: that is how one factor is
switched off in turn. v3's and v4's own factors are switched off with ``False``
(``gyro_cutoff``: 0; ``estimator_wrench``: ``"applied"``). Imports nothing above
``benchmark_v4`` and ``sensing.models``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from quad_dob_env.benchmark_v3 import REAL_LOOPS, butterworth_gain
from quad_dob_env.benchmark_v4 import V4_LOOPS
from quad_dob_env.sensing.models import SensorSuite, resolve_sensing
from quad_dob_env.validation import unknown_name_error

BENCHMARKS = ("v1", "v2", "v3", "v4")
# the benchmark the command-line tools (evaluate, --suite, tune, check-controller, the
# leaderboard, wind-tunnel, make demo) fly when none is given: the newest. The library's
# scenarios keep v1 unless told, so code written against v1 flies as it did.
TOOLS_BENCHMARK = "v4"
# Benchmark v2's inner loop [Hz]: PX4's attitude loop rate (IMU_INTEG_RATE, 200 Hz by
# default; its rate loop runs at IMU_GYRO_RATEMAX, 400 Hz), over the 100 Hz position loop
# of dt = 0.01 s. There the full v2 loop with the base at N = 1024 keeps 0.38-0.43 of v1's
# throughput, above the third asked for; at 400 Hz 0.28-0.32 (docs/benchmark-v2-loop.md,
# "Speed of the vehicle loop").
V2_INNER_RATE = 200.0
V2_SENSING = "mocap"
# the fields a benchmark sets where the scenario leaves them None: v2's, then v3's own
V2_LOOP_FIELDS = ("sensing", "inner_rate", "speed_motors", "thrust_uncertainty",
                  "rotor_aerodynamics", "drag")
V3_LOOP_FIELDS = ("motor_time_constants", "throttle_map", "model_tolerance", "gyro_cutoff",
                  "imu_vibration", "pose_latency_on_ticks")
V4_LOOP_FIELDS = ("estimator_wrench", "airframe_drag", "imu_vibration_tones")
LOOP_FIELDS = V2_LOOP_FIELDS + V3_LOOP_FIELDS + V4_LOOP_FIELDS
# the benchmarks that fly v3's sourced loop (v4 corrects five of its mechanisms over it)
REAL_LOOP_BENCHMARKS = ("v3", "v4")


def v2_inner_rate(dt: float, rate: float = V2_INNER_RATE) -> float:
    """The smallest whole multiple of 1/dt at or above ``rate`` (v2's by default)."""
    return math.ceil(rate * dt - 1e-9) / dt


def v3_loop(vehicle: Any, name: str, benchmark: str = "v3") -> dict[str, Any]:
    """v3's own loop fields for ``vehicle`` (a ``VehicleParams``), from its sourced values."""
    if vehicle.name not in REAL_LOOPS:
        raise ValueError(f"benchmark={benchmark!r} flies sourced values of the real vehicle's "
                         f"loop, which exist for the vehicles {sorted(REAL_LOOPS)}; scenario "
                         f"{name!r} flies {vehicle.name!r}: use one of those, or "
                         "benchmark='v2'")
    real = REAL_LOOPS[vehicle.name]
    # the rotors' hover frequency [Hz], where their vibration sits
    rotor_frequency = math.sqrt(vehicle.hover_thrust / 4 / vehicle.thrust_coefficient) / (
        2 * math.pi)
    return {"motor_time_constants": real.motor_time_constants,
            "throttle_map": real.throttle_map, "model_tolerance": real.model_tolerance,
            "gyro_cutoff": real.gyro_cutoff,
            "imu_vibration": (real.gyroscope_vibration, real.accelerometer_vibration
                              * butterworth_gain(rotor_frequency, real.accelerometer_cutoff)),
            "pose_latency_on_ticks": True}


def v4_loop(vehicle: Any, name: str) -> dict[str, Any]:
    """v4's loop fields for ``vehicle``: v3's, with the five mechanisms v4 corrects
    (``quad_dob_env.benchmark_v4``): the estimators told the command, the fitted drag, the
    vibration as tones (in place of v3's white vibration), the identified throttle curve."""
    fields = v3_loop(vehicle, name, "v4")
    v4 = V4_LOOPS[vehicle.name]
    return {**fields, "throttle_map": v4.throttle_map, "imu_vibration": None,
            "estimator_wrench": "commanded", "airframe_drag": v4.airframe_drag,
            "imu_vibration_tones": v4.vibration}


# what each of v3's and v4's own fields is when off (given as False, ``gyro_cutoff`` as 0;
# the estimators then told the rotors' output, as v1-v3)
V3_OFF = {"motor_time_constants": None, "throttle_map": None, "model_tolerance": None,
          "gyro_cutoff": None, "imu_vibration": None, "pose_latency_on_ticks": False}
V4_OFF = {"estimator_wrench": "applied", "airframe_drag": None, "imu_vibration_tones": None}
OFF = {**V3_OFF, **V4_OFF}


def loop_fields(benchmark: Any, given: dict[str, Any], dt: float, actuation: str,
                name: str, vehicle: Any = None) -> dict[str, Any]:
    """The loop fields of a scenario flown under ``benchmark``: those ``given`` (not None)
    as they are, the rest the benchmark's; ``inner_rate`` 0 means none, and v3's and v4's fields
    given "off" their ``OFF`` value (``V3_OFF``, ``V4_OFF``)."""
    if benchmark not in BENCHMARKS:
        raise unknown_name_error("benchmark", benchmark, BENCHMARKS)
    loop = benchmark in ("v2", *REAL_LOOP_BENCHMARKS)
    if loop and actuation != "rotors":
        raise ValueError(f"benchmark={benchmark!r} flies rotors (speed motors, rotor "
                         f"aerodynamics), but scenario {name!r} flies actuation={actuation!r},"
                         " the paper's wrench: the paper-* scenarios are v1-only "
                         "(benchmark='v1')")
    v3 = benchmark in REAL_LOOP_BENCHMARKS
    rate = REAL_LOOPS[vehicle.name].inner_rate if v3 and vehicle.name in REAL_LOOPS else (
        V2_INNER_RATE)
    own = (v4_loop(vehicle, name) if benchmark == "v4" else
           {**v3_loop(vehicle, name), **V4_OFF} if v3 else OFF)
    defaults = {"sensing": V2_SENSING if loop else None,
                "inner_rate": v2_inner_rate(dt, rate) if loop else None,
                "speed_motors": loop, "thrust_uncertainty": benchmark == "v2",
                "rotor_aerodynamics": loop,
                # the air-relative velocity the rotors' aerodynamics act on
                "drag": loop,
                **own}
    resolved = {key: defaults[key] if given.get(key) is None else given[key]
                for key in LOOP_FIELDS}
    if given["rotor_aerodynamics"] is None and given["drag"] is not None:
        # drag switched off by hand takes the rotors' aerodynamics (which act through the
        # air-relative velocity it turns on) with it
        resolved["rotor_aerodynamics"] = resolved["rotor_aerodynamics"] and bool(given["drag"])
    if isinstance(resolved["inner_rate"], (int, float)) and resolved["inner_rate"] == 0:
        resolved["inner_rate"] = None
    for key, off in OFF.items():
        value = resolved[key]
        if value is False or (key == "gyro_cutoff" and value == 0):
            resolved[key] = off
    if v3 and given["thrust_uncertainty"] and given.get("throttle_map") is None:
        # v2's thrust draws asked for by hand under v3 replace its throttle map
        resolved["throttle_map"] = None
    # a part of the loop switched off by hand takes the v3 factors that act through it
    # with it, unless they were given too (then the scenario refuses the pair)
    suite = isinstance(resolve_sensing(resolved["sensing"]), SensorSuite)
    needs = {"throttle_map": not resolved["speed_motors"],
             "motor_time_constants": not resolved["speed_motors"],
             "model_tolerance": not resolved["speed_motors"],
             "gyro_cutoff": resolved["inner_rate"] is None,
             # a sensor suite's IMU and pose fix
             "imu_vibration": not suite, "pose_latency_on_ticks": not suite,
             "imu_vibration_tones": not suite,
             # the drag's coefficients act through the air-relative velocity drag turns on
             "airframe_drag": not resolved["drag"]}
    for key, missing in needs.items():
        if missing and given.get(key) is None:
            resolved[key] = OFF[key]
    return resolved


def scenario_options_for(options: dict[str, Any] | None, benchmark: str | None
                         ) -> dict[str, Any]:
    """``options`` for ``make_scenario`` with ``benchmark`` beneath them (what an env's
    ``benchmark=`` keyword, the ``-v2`` and ``-v3`` ids', adds: an option given wins).
    ``options`` that are not a mapping are refused, naming what was given."""
    if options is not None and not isinstance(options, Mapping):
        raise ValueError(f"scenario_options must be a dict of make_scenario's keywords (for "
                         f"example {{'wind_scale': 1.5}}), got {type(options).__name__} "
                         f"{options!r}")
    return {**({} if benchmark is None else {"benchmark": benchmark}), **(options or {})}
