"""A configuration fuzzer: random ids, scenarios, options, actions and vectorisation.

Run by hand: ``python tests/fuzz.py --configs 1000 --seed 0`` (the test suite runs a small
profile, ``tests/test_fuzz.py``, without the wall-clock checks). Every configuration is
drawn from its own seeded generator, ``numpy.random.default_rng([seed, index])``, as a
user could combine things: an env id, maybe another scenario by name, single env
(``gym.make``) or vector env (``gym.make_vec``, ``vector_entry_point`` or ``sync``, 1-8
vehicles); options of the
scenario and of the env, mostly valid, some not (a string where a number goes, None, a
negative, NaN, a huge value, an unknown name); actions in [-1, 1], at the extremes, out of
range, sometimes NaN or infinite, sometimes of the wrong shape or type.

What counts:

- *refused*: building (or the first reset) raised a ValueError with a message, or a
  ``gymnasium.error.Error``: bad input got a clear error.
- *refused by Gymnasium*: an argument Gymnasium itself handles (``num_envs``, a
  ``max_episode_steps`` for its ``TimeLimit``) was invalid and Gymnasium raised.
- a *failure*, anything else: any other exception (TypeError, KeyError, IndexError,
  ZeroDivisionError, MemoryError, AssertionError, numba's, a ValueError without a message,
  a ValueError while flying valid actions); a non-finite value in an observation, reward or
  ``info``; an observation outside the observation space; a non-bool terminated or
  truncated; an episode that ended without a known ``termination_reason``; a NaN action
  not refused (``invalid_actions="raise"``) or not ending its episode with
  ``invalid_action`` (``"terminate"``); an episode truncated before the scenario's end when
  the user asked for no shorter limit (``early_truncation``), or not truncated there;
  a scenario option that did not reach the scenario; a request for more memory than the
  budget that was not refused at once (``memory_not_refused``); a configuration that ran
  past its time limit.

Requests whose size comes from a huge option (a start spread of 10⁷ s, ``dt = 1e-4`` on the
training pool, a billion vehicles) run in a child process with an address-space limit, so a
request that is not refused cannot take the machine with it.

``--only K`` reruns configuration K alone, prints it, a Python reproduction and the full
traceback of any failure.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import dataclasses
import functools
import hashlib
import json
import math
import os
import resource
import signal
import subprocess
import sys
import threading
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

import quad_dob_env
from quad_dob_env import scenarios as scenario_registry

ROOT = Path(__file__).resolve().parent.parent
ENV_IDS = list(quad_dob_env.ENV_IDS)
SCENARIOS = quad_dob_env.list_scenarios()
FAMILIES = ("random-tracks", "random-lemniscates")
# builder options per scenario, as make_scenario reads them
BUILDER_OPTIONS: dict[str, tuple[str, ...]] = dict(
    getattr(scenario_registry, "_BUILDER_OPTIONS", {}))
CONTROLLERS = ("geometric", "geometric-ndob", "geometric-ndob:tuned",
               "geometric-ndob:gains-tuned", "pid", "smc")
REASONS = {"crashed", "out_of_bounds", "attitude_lost", "non_finite_state", "invalid_action",
           "time_limit"}
MODES = ("single", "vector_entry_point", "sync")
ISOLATED_MEMORY_LIMIT = 6 * 2**30  # address space of a child running a huge request
ISOLATED_TIMEOUT = 30.0  # [s] a huge request must be refused well within this
HANG_STOP = 900.0  # [s] a child given no timeout is stopped after this: it hangs
MAX_TABLE_STEPS = 3000  # duration / dt of a drawn configuration (families: half)

NAN, INF = float("nan"), float("inf")
# values that no numeric option takes
BAD_NUMBERS: tuple[Any, ...] = ("0.01", None, NAN, INF, -INF, True, [1.0, 2.0], "fast")


class FuzzTimeout(BaseException):
    """A configuration ran past its time limit (not an Exception: nothing may swallow it)."""


# ---------------------------------------------------------------------------------------
# drawing a configuration


class _Draw:
    """One configuration's generator, and the names of the options drawn invalid."""

    def __init__(self, rng: np.random.Generator, bad: float = 1.0) -> None:
        self.rng = rng
        self.bad = bad  # scales every chance of a bad value: 0 in a configuration meant valid
        self.invalid: list[str] = []
        self.huge: list[str] = []

    def chance(self, p: float) -> bool:
        return bool(self.rng.random() < p)

    def bad_chance(self, p: float) -> bool:
        """A chance of a bad value: none in a configuration meant valid."""
        return self.chance(p * self.bad)

    def pick(self, items: Any) -> Any:
        items = list(items)
        return items[int(self.rng.integers(len(items)))]

    def number(self, name: str, low: float, high: float, *, log: bool = False,
               integer: bool = False, bad: float = 0.08, huge: Any = None,
               extra_bad: tuple = (), none_ok: bool = False) -> Any:
        """A value in [low, high] mostly; now and then one of the bad ones or ``huge``."""
        roll = self.rng.random()
        bad *= self.bad
        if roll < bad:
            pool = [v for v in (*BAD_NUMBERS, *extra_bad) if not (v is None and none_ok)]
            self.invalid.append(name)
            return self.pick(pool)
        if huge is not None and roll < bad + 0.02 * self.bad:
            self.huge.append(name)
            return huge
        if integer:
            return int(self.rng.integers(int(low), int(high) + 1))
        if log:
            return float(math.exp(self.rng.uniform(math.log(low), math.log(high))))
        return float(self.rng.uniform(low, high))

    def name(self, name: str, valid: tuple, bad: tuple, p_bad: float = 0.06) -> Any:
        if self.chance(p_bad * self.bad):
            self.invalid.append(name)
            return self.pick(bad)
        return self.pick(valid)


def _sensors(d: _Draw) -> Any:
    if d.bad_chance(0.05):
        d.invalid.append("sensors")
        return d.pick(["noisy", 3, [0.1, 0.1]])
    sensors: dict[str, Any] = {}
    for key, high in (("position_std", 0.1), ("velocity_std", 0.2), ("attitude_std", 0.05),
                      ("rate_std", 0.1)):
        if d.chance(0.5):
            sensors[key] = d.number(f"sensors.{key}", 0.0, high, bad=0.05,
                                    extra_bad=(-0.1,))
    if d.chance(0.4):
        sensors["delay_steps"] = d.number("sensors.delay_steps", 0, 5, integer=True, bad=0.05,
                                          extra_bad=(-1, 2.5), huge=10**9)
    if d.bad_chance(0.03):
        d.invalid.append("sensors.bias")
        sensors["bias"] = 0.1
    return sensors


def _pair(d: _Draw, name: str) -> Any:
    if d.bad_chance(0.08):
        d.invalid.append(name)
        return d.pick([(1.2, 0.8), (0.0, 1.0), 1.1, (NAN, 1.0), (1.0,), ("0.9", "1.1"),
                       (-1.0, 1.0)])
    low = float(d.rng.uniform(0.7, 1.0))
    return (low, float(low + d.rng.uniform(0.0, 0.4)))


def _randomization(d: _Draw) -> Any:
    if d.bad_chance(0.04):
        d.invalid.append("randomization")
        return d.pick(["on", 1.0])
    chosen = {key: _pair(d, f"randomization.{key}") for key in ("mass", "inertia", "drag")
              if d.chance(0.6)}
    if d.bad_chance(0.03):
        d.invalid.append("randomization.gravity")
        chosen["gravity"] = (0.9, 1.1)
    return chosen


def _vehicle_loop_options(d: _Draw, scenario: str, options: dict[str, Any]) -> None:
    """Benchmark v2's vehicle-loop switches: an inner rate (a multiple of the control rate,
    now and then not), and the rotor factors, marked invalid where the scenario has no
    rotors (wrench actuation) or, for the rotor aerodynamics, no drag. Drawn from a stream
    of their own, so every other draw of a configuration is what it was without them."""
    own = _Draw(d.rng.spawn(1)[0], d.bad)
    own.invalid, own.huge = d.invalid, d.huge
    d = own
    if d.chance(0.08):
        if d.bad_chance(0.1):
            d.invalid.append("inner_rate")
            options["inner_rate"] = d.pick([150.0, -100.0, 0.0, float("nan")])
        else:
            dt = options.get("dt", 0.01)
            options["inner_rate"] = d.pick([1, 2, 4]) / dt if isinstance(dt, float) else 200.0
    defaults = _actuation_and_drag(scenario)
    if defaults is None:
        return  # a bad scenario name: its own refusal comes first
    rotors = options.get("actuation", defaults[0]) == "rotors"
    if d.chance(0.06):  # Benchmark v2's whole loop, refused where the vehicle has no rotors
        if d.bad_chance(0.2):
            options["benchmark"] = d.pick(["v4", "V2", 2, None])
            d.invalid.append("benchmark")
        else:
            options["benchmark"] = d.pick(["v1", "v2"])
            if options["benchmark"] == "v2" and not rotors:
                d.invalid.append("benchmark")
    for key in ("speed_motors", "thrust_uncertainty", "rotor_aerodynamics"):
        if d.chance(0.06):
            options[key] = True
            if not rotors:
                d.invalid.append(key)
            elif key == "rotor_aerodynamics" and not options.get("drag", defaults[1]):
                d.invalid.append(key)


# the vehicles Benchmark v3 has sourced values for (quad_dob_env.benchmark_v3.REAL_LOOPS)
V3_VEHICLES = ("paper", "neural-fly")


def _v3_options(d: _Draw, scenario: str, options: dict[str, Any]) -> None:
    """Now and then Benchmark v3 (refused where the scenario has no rotors or its vehicle no
    sourced values) and each of v3's own factors: off, at a value of its own (refused where
    the part of the loop it acts through is off), or at a bad value. From a stream of its
    own, so every other draw of a configuration is what it was without them."""
    own = _Draw(d.rng.spawn(1)[0], d.bad)
    own.invalid, own.huge = d.invalid, d.huge
    d = own
    defaults = _actuation_and_drag(scenario)
    if defaults is None or "benchmark" in options or not d.chance(0.08):
        return
    options["benchmark"] = "v3"
    if options.get("actuation", defaults[0]) != "rotors":
        d.invalid.append("benchmark v3 without rotors")
    if options.get("vehicle", defaults[2]) not in (*V3_VEHICLES, "mavic",
                                                                   "Paper", 7):
        d.invalid.append("benchmark v3 on a vehicle without sourced values")
    dt = options.get("dt", 0.01)
    inner = options.get("inner_rate", math.ceil(200.0 * dt - 1e-9) / dt if isinstance(
        dt, float) and dt > 0 else 200.0)
    no_imu = options.get("sensing") == "ideal" or (
        options.get("sensors") is not None and "sensing" not in options)
    values = {"motor_time_constants": ((0.03, 0.08), (0.03,), None),
              "throttle_map": ({"thrust_model_factor": 0.5, "hover_throttle": (0.45, 0.5)},
                               {"thrust_model_factor": 2.0, "hover_throttle": (0.4, 0.5)},
                               "thrust_uncertainty" if options.get("thrust_uncertainty")
                               else None),
              "model_tolerance": ({"mass": 0.05, "inertia": 0.1}, {"mass": 1.5}, None),
              "gyro_cutoff": (20.0, -5.0, "inner_rate" if not isinstance(inner, float)
                              or inner / 2 <= 20.0 else None),
              "imu_vibration": ((0.01, 0.5), (-0.1, 0.0), "sensing" if no_imu else None),
              "pose_latency_on_ticks": (True, "yes", None),
              "unmodelled_pose_latency": (0.02, -0.01, "sensing" if no_imu else None)}
    for key, (value, bad, conflict) in values.items():
        if not d.chance(0.3):
            continue
        if d.bad_chance(0.1):
            options[key] = bad
            d.invalid.append(key)
        elif d.chance(0.4):
            options[key] = {"gyro_cutoff": 0, "unmodelled_pose_latency": 0.0}.get(key, False)
        else:
            options[key] = value
            if conflict is not None:
                d.invalid.append(f"{key} with {conflict}")


def _later_id(rng: np.random.Generator, config: dict[str, Any], scenario: str,
              options: dict[str, Any]) -> None:
    """Now and then the drawn id's ``-v2`` or ``-v3`` counterpart (that benchmark's loop
    beneath the options), from a stream of its own so no other draw moves; refused where
    the options leave the benchmark to the id and the flown scenario has no rotors (or,
    for v3, its vehicle has no sourced values)."""
    version = "-v2" if rng.random() < 0.5 else "-v3"
    later = config["env_id"].replace("-v1", version)
    if (later == config["env_id"] or later not in {**quad_dob_env.ENV_IDS_V2,
                                                   **quad_dob_env.ENV_IDS_V3}
            or rng.random() > 0.1):
        return
    config["env_id"] = later
    defaults = _actuation_and_drag(scenario)
    if defaults is None or "benchmark" in options or "benchmark" in config["invalid"]:
        return
    if options.get("actuation", defaults[0]) != "rotors":
        config["invalid"].append("benchmark")
    elif version == "-v3" and options.get("vehicle", defaults[2]) not in (
            *V3_VEHICLES, "mavic", "Paper", 7):
        config["invalid"].append("benchmark v3 on a vehicle without sourced values")


@functools.cache
def _actuation_and_drag(scenario: str) -> tuple[str, bool, str] | None:
    """A named scenario's default actuation, drag and vehicle name (None: no such
    scenario)."""
    try:
        built = scenario_registry.make_scenario(scenario)
    except (ValueError, TypeError):
        return None
    return built.actuation, built.drag, built.vehicle.name


def _scenario_options(d: _Draw, scenario: str) -> dict[str, Any]:
    """Options for ``make_scenario(scenario, ...)``: its builder's and ``Scenario`` fields."""
    builder = BUILDER_OPTIONS.get(scenario, ())
    options: dict[str, Any] = {}
    if d.chance(0.3):
        options["dt"] = d.number("dt", 0.002, 0.05, log=True, extra_bad=(0.0, -0.01, 0.5))
    if d.chance(0.3):
        options["duration"] = d.number("duration", 0.2, 15.0, extra_bad=(0.0, -1.0),
                                       huge=1e9)
    if d.chance(0.12):
        options["substeps"] = d.number("substeps", 1, 4, integer=True,
                                       extra_bad=(0, 101, 2.5, -1))
    if d.chance(0.15):
        options["reference_start_spread"] = d.number(
            "reference_start_spread", 0.0, 5.0, extra_bad=(-1.0,), huge=1e300)
    for key in ("drag", "motor_lag"):
        if d.chance(0.1):
            options[key] = d.pick([True, False])
    if d.chance(0.12):
        options["sensors"] = None if d.chance(0.1) else _sensors(d)
    if d.chance(0.1):
        options["sensing"] = d.name("sensing", ("ideal", "mocap", "gnss-imu"),
                                    ("mocup", "MOCAP ", 3))
        if (options.get("sensors") is not None
                and options["sensing"] in ("mocap", "gnss-imu")):
            d.invalid.append("sensing+sensors")  # two sensings at once
    if d.chance(0.08):
        options["extra_latency"] = d.number("extra_latency", 0.0, 0.05, extra_bad=(-0.01,),
                                            huge=1e7)
    if d.chance(0.05):
        options["motor_lag"] = True
        options["motor_time_constant_scale"] = d.number(
            "motor_time_constant_scale", 0.5, 3.0, extra_bad=(0.0, -1.0))
    if d.chance(0.12):
        options["randomization"] = None if d.chance(0.1) else _randomization(d)
    if d.chance(0.05):
        options["actuation"] = d.name("actuation", ("rotors", "wrench"), ("motors", "Rotors"))
    _vehicle_loop_options(d, scenario, options)
    if d.chance(0.05):
        options["initial_position_noise"] = d.number("initial_position_noise", 0.0, 0.3,
                                                     extra_bad=(-0.1,))
    if d.chance(0.05):
        options["initial_attitude_noise"] = d.number("initial_attitude_noise", 0.0, 0.5,
                                                     extra_bad=(-0.1, 4.0))
    if d.chance(0.03):
        options["allow_infeasible"] = True
    # the builder's own options, mostly where the scenario takes them
    if "vehicle" in builder and d.chance(0.08):
        options["vehicle"] = d.name("vehicle", ("paper", "crazyflie"), ("mavic", "Paper", 7))
    if "wind_scale" in builder and d.chance(0.25):
        options["wind_scale"] = d.number("wind_scale", 0.0, 3.0, extra_bad=(-1.0,))
    if "wind" in builder and d.chance(0.15):
        options["wind"] = d.name("wind", ("calm", "light", "moderate"), ("storm", "Light"))
    if "altitude" in builder and d.chance(0.08):
        options["altitude"] = d.number("altitude", 1.0, 5.0, extra_bad=(-1.0, 0.0))
    if "height" in builder and d.chance(0.08):
        options["height"] = d.number("height", 0.3, 3.0, extra_bad=(-1.0, 0.0))
    if "step_force" in builder and d.chance(0.1):
        options["step_force"] = d.number("step_force", 0.0, 0.4)
    if "torque_reading" in builder and d.chance(0.15):
        options["torque_reading"] = d.name("torque_reading", ("0.6*dx", "dx/0.6"), ("0.6",))
    if "model" in builder and d.chance(0.15):
        options["model"] = d.name("model", ("paper", "cheeseman-bennett"), ("cheeseman",))
    if d.bad_chance(0.04):  # an option this scenario does not take
        foreign = d.pick(["wind", "wind_scale", "altitude", "height", "torque_reading",
                          "speed", "gusts"])
        if foreign not in builder:
            d.invalid.append(f"foreign option {foreign}")
            options[foreign] = 1.0 if foreign != "wind" else "light"
    _v3_options(d, scenario, options)
    _bound_tables(options, scenario)
    return options


def _bound_tables(options: dict[str, Any], scenario: str) -> None:
    """Keep a valid-looking duration / dt under the table cap (families: half of it)."""
    dt, duration = options.get("dt", 0.01), options.get("duration", None)
    if not (isinstance(dt, float) and 0 < dt < 1):
        return
    cap = MAX_TABLE_STEPS // (2 if scenario in FAMILIES else 1)
    default = 10.0
    if isinstance(duration, float) and duration < 1e8:
        if duration / dt > cap:
            options["duration"] = round(cap * dt, 6)
    elif duration is None and default / dt > cap:
        options["duration"] = round(cap * dt, 6)
    spread = options.get("reference_start_spread")
    if isinstance(spread, float) and spread < 1e8 and spread / dt > cap:
        options["reference_start_spread"] = round(cap * dt, 6)


def _env_kwargs(d: _Draw, env_id: str, mode: str) -> dict[str, Any]:
    residual = "Residual" in env_id
    kwargs: dict[str, Any] = {}
    if d.chance(0.2):
        kwargs["action_mode"] = d.name(
            "action_mode", ("thrust_moments", "rotor_thrusts") if residual else
            ("thrust_moments", "rotor_thrusts", "thrust_rates"), ("thrust", "rates"))
    if d.chance(0.2):
        kwargs["rotation_representation"] = d.name("rotation_representation",
                                                   ("matrix", "6d"), ("quaternion", "6D"))
    if d.chance(0.6):
        kwargs["invalid_actions"] = d.name("invalid_actions", ("raise", "terminate"),
                                           ("ignore", "clip"))
    if d.chance(0.2):
        if d.bad_chance(0.1):
            kwargs["max_episode_steps"] = d.pick([0, -5, 2.5, "100", True])
            d.invalid.append("max_episode_steps")
        elif d.chance(0.1):
            kwargs["max_episode_steps"] = None
        else:
            kwargs["max_episode_steps"] = int(d.pick([d.rng.integers(5, 300), 5000]))
    for name, low, high, bad in (("max_position_error", 0.5, 20.0, (0.0, -1.0)),
                                 ("max_tilt", 0.3, 3.1, (0.0, -1.0)),
                                 ("max_body_rate", 5.0, 60.0, (0.0, -1.0)),
                                 ("reward_position_scale", 0.05, 1.0, (0.0, -1.0)),
                                 ("reward_effort_weight", 0.0, 0.1, (-0.1,))):
        if d.chance(0.05):
            kwargs[name] = d.number(name, low, high, extra_bad=bad)
    if mode != "single" and d.chance(0.3):
        valid = ("NextStep", "SameStep")
        kwargs["autoreset_mode"] = (d.name("autoreset_mode", valid,
                                           ("Disabled", "never", "next_step"))
                                    if mode == "vector_entry_point" else d.pick(valid))
    if mode != "sync" and d.chance(0.03):
        kwargs["render_mode"] = d.name("render_mode", ("rgb_array",), ("ascii",), 0.2)
    if residual:
        if d.chance(0.3):
            kwargs["base_controller"] = d.name("base_controller", CONTROLLERS,
                                               ("lqr", "Geometric", None, 3))
        for name, low, high, bad in (("thrust_scale", 0.01, 1.0, (0.0, 2.0, -0.1)),
                                     ("moment_scale", 0.01, 1.0, (0.0, 2.0, -0.1)),
                                     ("residual_effort_weight", 0.0, 0.1, (-0.1,)),
                                     ("acceleration_scale", 0.5, 6.0, (0.0, -1.0)),
                                     ("vertical_floor", 0.0, 0.9, (-0.5,))):
            if d.chance(0.08):
                kwargs[name] = d.number(name, low, high, extra_bad=bad)
        if d.chance(0.2):
            kwargs["authority_gate"] = d.number("authority_gate", 0.05, 1.0, none_ok=True,
                                                extra_bad=(0.0, -0.5))
        if d.chance(0.3):
            kwargs["residual_mode"] = d.name("residual_mode", ("thrust_moments", "acceleration"),
                                             ("accel", "moments"))
        if mode == "vector_entry_point" and d.chance(0.1):
            kwargs["compiled"] = d.pick([True, False])
    return kwargs


def _actions_plan(d: _Draw, mode: str) -> dict[str, Any]:
    plan: dict[str, Any] = {
        "kind": d.pick(["uniform"] * 4 + ["extremes"] * 2 + ["out_of_range"] * 2
                       + ["zeros", "mixed", "mixed"]),
        "nan_rate": float(d.pick([0.0] * 6 + [0.005, 0.02, 0.1])),
        "container": d.pick(["float32", "float64", "float64"]
                            + (["list"] if mode != "sync" else [])),
        "bad_rate": float(d.pick([0.0] * 19 + [0.05])) if mode != "sync" else 0.0,
    }
    return plan


MEMORY_HUNGRY: tuple[dict[str, Any], ...] = (
    # each asks for far more than the memory budget (4 GiB): it must be refused at once
    {"env_id": None, "scenario_options": {"reference_start_spread": 1e7}},
    {"env_id": "QuadDOB/TracksResidual-v1", "scenario_options": {"dt": 1e-4}},
    {"env_id": "QuadDOB/TracksResidual-v1", "scenario_options": {"dt": 1e-4,
                                                                 "reference_start_spread": 1e3}},
    {"env_id": "QuadDOB/Track-v1", "scenario": "random-lemniscates",
     "scenario_options": {"dt": 1e-4, "duration": 100.0}},
    {"env_id": "QuadDOB/TracksResidual-v1", "scenario_options": {"duration": 1e4}},
    {"env_id": None, "mode": "vector_entry_point", "num_envs": 10**9},
    {"env_id": None, "scenario_options": {"sensors": {"delay_steps": 10**10}}},
)


def _wrappers(d: _Draw, mode: str) -> list[str]:
    """Gymnasium's wrappers around the env, none twice (RecordEpisodeStatistics refuses)."""
    names = list(SINGLE_WRAPPERS if mode == "single" else VECTOR_WRAPPERS)
    count = int(d.pick([0] * 8 + [1, 2]))
    return [str(name) for name in d.rng.permutation(names)[:count]]


def draw_config(seed: int, index: int) -> dict[str, Any]:
    """Configuration ``index`` of run ``seed``: a plain dict, reproducible from the two."""
    rng = np.random.default_rng([seed, index])
    # a third of the configurations may hold bad input; the others only valid-looking values
    d = _Draw(rng, bad=3.0 if rng.random() < 1 / 3 else 0.0)
    config: dict[str, Any] = {"index": index, "fuzz_seed": seed}
    env_id = d.pick(ENV_IDS)
    mode = d.pick(["single"] * 4 + ["vector_entry_point"] * 4 + ["sync"] * 2)
    num_envs: Any = int(d.rng.integers(1, 9))
    upstream_invalid = False
    if mode != "single" and d.bad_chance(0.03):
        num_envs = d.pick([0, -1, 2.5, "4"])
        d.invalid.append("num_envs")
        upstream_invalid = mode == "sync"
    if d.bad_chance(0.03):  # an id that is not registered
        env_id = d.pick(["QuadDOB/Track-v0", "QuadDOB/Tracks-v1", "quaddob/track-v1"])
        d.invalid.append("env_id")
    scenario = None
    if d.chance(0.5):
        if d.bad_chance(0.04):
            scenario = d.pick(["paper-III", "Paper-II", "", "hover"])
            d.invalid.append("scenario")
        else:
            scenario = d.pick(SCENARIOS)
    default = quad_dob_env.ENV_IDS.get(env_id, "paper-none")
    kwargs = _env_kwargs(d, env_id, mode)
    options = _scenario_options(d, scenario or default) if d.chance(0.7) else {}
    if scenario is not None:
        kwargs["scenario"] = scenario
    if options:
        kwargs["scenario_options"] = options
    if mode in ("single", "sync") and "max_episode_steps" in d.invalid:
        upstream_invalid = True  # Gymnasium's TimeLimit takes it
    config.update(env_id=env_id, mode=mode, num_envs=num_envs if mode != "single" else 1,
                  kwargs=kwargs, actions=_actions_plan(d, mode),
                  steps=int(d.rng.integers(50, 201)), to_the_end=d.chance(0.15),
                  reset_after_end=not d.chance(0.05), seed=int(d.rng.integers(0, 2**31)),
                  replay=d.chance(0.05),
                  wrappers=_wrappers(d, mode),
                  invalid=d.invalid, huge=d.huge, upstream_invalid=upstream_invalid,
                  memory_hungry=False)
    _later_id(np.random.default_rng([seed, index, 2]), config, scenario or default, options)
    if d.chance(0.03):
        hungry = dict(d.pick(MEMORY_HUNGRY))
        config["env_id"] = hungry.pop("env_id") or config["env_id"]
        config["mode"] = hungry.pop("mode", config["mode"])
        config["num_envs"] = hungry.pop("num_envs", int(d.rng.integers(1, 9)))
        kwargs = {"scenario_options": hungry["scenario_options"]} if "scenario_options" in \
            hungry else {}
        if "scenario" in hungry:
            kwargs["scenario"] = hungry["scenario"]
        config.update(kwargs=kwargs, memory_hungry=True, invalid=[], huge=[],
                      upstream_invalid=False)
    return config


# ---------------------------------------------------------------------------------------
# outcomes


@dataclass
class Failure:
    category: str
    index: int
    fuzz_seed: int
    message: str  # the traceback's last line, or what was wrong
    where: str = ""  # the innermost frame in the repository: file:line in function
    phase: str = ""
    config: dict[str, Any] = field(default_factory=dict)
    traceback: str = ""

    @property
    def key(self) -> tuple[str, str, str]:
        """What makes two failures the same: category, exception type, place."""
        kind = self.message.split(":")[0] if self.category.startswith("exception") else ""
        return (self.category, kind, self.where)

    def describe(self) -> str:
        return (f"[{self.category}] config {self.index} (seed {self.fuzz_seed}, phase "
                f"{self.phase}): {self.message}" + (f"\n    at {self.where}" if self.where
                                                     else "")
                + f"\n    repro: python tests/fuzz.py --seed {self.fuzz_seed} "
                  f"--only {self.index}\n    config: {_short(self.config)}")


@dataclass
class Outcome:
    index: int
    status: str = "built"  # built | refused | upstream | failed
    mode: str = ""
    built: bool = False  # the env was made (whatever happened next)
    refusal: str = ""
    failures: list[Failure] = field(default_factory=list)
    reasons: collections.Counter = field(default_factory=collections.Counter)
    step_calls: int = 0
    vehicle_steps: int = 0
    actions_refused: int = 0
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    wall: float = 0.0
    isolated: bool = False

    def to_json(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["reasons"] = dict(self.reasons)
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Outcome:
        data = dict(data)
        data["reasons"] = collections.Counter(data["reasons"])
        data["failures"] = [Failure(**f) for f in data["failures"]]
        return cls(**data)


@dataclass
class FuzzReport:
    seed: int
    configs: int = 0
    built: collections.Counter = field(default_factory=collections.Counter)  # by mode
    refused: int = 0
    upstream: int = 0
    failures: list[Failure] = field(default_factory=list)
    reasons: collections.Counter = field(default_factory=collections.Counter)
    step_calls: int = 0
    vehicle_steps: int = 0
    actions_refused: int = 0
    isolated: int = 0
    refusals: collections.Counter = field(default_factory=collections.Counter)
    accepted_invalid: collections.Counter = field(default_factory=collections.Counter)
    notes: collections.Counter = field(default_factory=collections.Counter)
    warnings: collections.Counter = field(default_factory=collections.Counter)
    slowest: list[tuple[float, int]] = field(default_factory=list)
    wall: float = 0.0

    def add(self, outcome: Outcome, config: dict[str, Any]) -> None:
        self.configs += 1
        if outcome.status == "refused":
            self.refused += 1
            self.refusals[_refusal_kind(outcome.refusal)] += 1
        elif outcome.status == "upstream":
            self.upstream += 1
        if outcome.built:
            self.built[outcome.mode] += 1
            if outcome.status == "built" and config["invalid"]:
                self.accepted_invalid.update(config["invalid"])
        self.failures += outcome.failures
        self.reasons.update(outcome.reasons)
        self.step_calls += outcome.step_calls
        self.vehicle_steps += outcome.vehicle_steps
        self.actions_refused += outcome.actions_refused
        self.isolated += outcome.isolated
        self.notes.update(outcome.notes)
        self.warnings.update(outcome.warnings)
        self.slowest = sorted([*self.slowest, (outcome.wall, outcome.index)], reverse=True)[:5]

    @property
    def failure_classes(self) -> dict[tuple[str, str, str], list[Failure]]:
        classes: dict[tuple[str, str, str], list[Failure]] = {}
        for failure in self.failures:
            classes.setdefault(failure.key, []).append(failure)
        return classes

    def failed_configs(self) -> int:
        return len({f.index for f in self.failures})

    def summary(self, refusals: int = 12) -> str:
        by_category = collections.Counter(f.category for f in self.failures)
        lines = [
            f"configurations tried: {self.configs} (seed {self.seed})",
            f"built: {sum(self.built.values())} ("
            + ", ".join(f"{m} {self.built[m]}" for m in MODES) + ")",
            f"refused with a clear error: {self.refused}",
            f"refused by Gymnasium for its own arguments: {self.upstream}",
            f"failed: {self.failed_configs()} configurations, {len(self.failures)} failures "
            f"in {len(self.failure_classes)} classes: {dict(by_category.most_common())}",
            f"  of which an uncaught exception: "
            f"{sum(n for c, n in by_category.items() if c.startswith('exception'))}, "
            f"a non-finite value: {sum(n for c, n in by_category.items() if 'non_finite' in c)}",
            f"episodes ended: {sum(self.reasons.values())} {dict(self.reasons.most_common())}",
            f"steps flown: {self.step_calls:,} step calls, {self.vehicle_steps:,} vehicle-steps; "
            f"invalid actions refused with ValueError: {self.actions_refused}",
            f"huge requests run in a child process: {self.isolated}",
            f"wall time: {self.wall:.1f} s ({self.wall / max(self.configs, 1):.3f} s per "
            f"configuration; slowest: "
            + ", ".join(f"#{i} {t:.1f} s" for t, i in self.slowest) + ")",
        ]
        if self.refusals:
            lines.append("most common refusals:")
            lines += [f"  {n:4d}  {kind}" for kind, n in self.refusals.most_common(refusals)]
        if self.accepted_invalid:
            lines.append("built although an option was drawn invalid (check these are "
                         f"meant to pass): {dict(self.accepted_invalid.most_common())}")
        if self.notes:
            lines.append(f"notes: {dict(self.notes.most_common())}")
        if self.warnings:
            lines.append("warnings:")
            lines += [f"  {n:4d}  {w}" for w, n in self.warnings.most_common(10)]
        for key, failures in self.failure_classes.items():
            lines.append(f"FAILURE CLASS {key[0]} ({len(failures)}x): "
                         + failures[0].describe())
        return "\n".join(lines)


def _refusal_kind(message: str) -> str:
    """A refusal's message without its values, to count kinds of refusal."""
    text = message.splitlines()[0] if message else ""
    for stop in (", got", "; valid", " would take", ": needs", " must be"):
        if stop in text:
            cut = text.index(stop)
            keep = {" must be": 40, " would take": 12}.get(stop, 0)
            return text[:cut + keep]
    return text[:90]


def _short(config: dict[str, Any]) -> str:
    keep = {k: config[k] for k in ("env_id", "mode", "num_envs", "kwargs", "wrappers",
                                   "actions", "steps", "seed") if k in config}
    return repr(keep)


# ---------------------------------------------------------------------------------------
# building and flying


def _autoreset(value: str) -> Any:
    try:
        return AutoresetMode(value)
    except ValueError:
        return value


SINGLE_WRAPPERS = ("TimeAwareObservation", "RecordEpisodeStatistics", "ClipAction",
                   "NormalizeObservation", "FlattenObservation")
VECTOR_WRAPPERS = ("RecordEpisodeStatistics", "ClipAction", "NormalizeObservation")


def build(config: dict[str, Any]) -> Any:
    """The env the configuration asks for, as a user would make it, in Gymnasium's
    wrappers the configuration names."""
    kwargs = dict(config["kwargs"])
    mode = config["mode"]
    if mode == "single":
        env = gym.make(config["env_id"], **kwargs)
    elif mode == "sync":
        vector_kwargs = {}
        if "autoreset_mode" in kwargs:
            vector_kwargs["autoreset_mode"] = _autoreset(kwargs.pop("autoreset_mode"))
        env = gym.make_vec(config["env_id"], num_envs=config["num_envs"],
                           vectorization_mode="sync", vector_kwargs=vector_kwargs, **kwargs)
    else:
        if "autoreset_mode" in kwargs:
            kwargs["autoreset_mode"] = _autoreset(kwargs["autoreset_mode"])
        env = gym.make_vec(config["env_id"], num_envs=config["num_envs"],
                           vectorization_mode="vector_entry_point", **kwargs)
    module = gym.wrappers if mode == "single" else gym.wrappers.vector
    for name in config.get("wrappers", ()):
        env = getattr(module, name)(env)
    return env


def _in_repository(filename: str) -> bool:
    path = os.path.abspath(filename)
    return path.startswith(str(ROOT)) and "/.venv/" not in path and "/benchmarks/" not in path


def _where(exc: BaseException) -> str:
    frames = traceback.extract_tb(exc.__traceback__)
    inside = [f for f in frames if _in_repository(f.filename)]
    frame = inside[-1] if inside else (frames[-1] if frames else None)
    if frame is None:
        return ""
    return f"{os.path.relpath(frame.filename, ROOT)}:{frame.lineno} in {frame.name}"


def _raised_by_gymnasium(exc: BaseException) -> bool:
    frames = traceback.extract_tb(exc.__traceback__)
    return bool(frames) and "/gymnasium/" in frames[-1].filename


def _clear_error(exc: BaseException) -> bool:
    if isinstance(exc, gym.error.Error):
        return bool(str(exc).strip())
    return type(exc) is ValueError and bool(str(exc).strip())


def _last_line(exc: BaseException) -> str:
    return traceback.format_exception_only(type(exc), exc)[-1].strip()[:400]


def _non_finite(value: Any, path: str = "") -> str | None:
    """The path of the first non-finite number in ``value`` (dicts, sequences, arrays)."""
    if isinstance(value, dict):
        for key, item in value.items():
            found = _non_finite(item, f"{path}[{key!r}]")
            if found:
                return found
    elif isinstance(value, np.ndarray):
        if value.dtype.kind in "fc":
            if not np.isfinite(value).all():
                return path
        elif value.dtype == object:
            for i, item in enumerate(value.reshape(-1)):
                found = _non_finite(item, f"{path}[{i}]")
                if found:
                    return found
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            found = _non_finite(item, f"{path}[{i}]")
            if found:
                return found
    elif isinstance(value, (float, complex, np.floating, np.complexfloating)):
        if not np.isfinite(value):
            return path
    return None


class _Flight:
    """Flies one built env and checks every step; failures go to ``outcome``."""

    def __init__(self, config: dict[str, Any], env: Any, outcome: Outcome) -> None:
        self.config, self.env, self.outcome = config, env, outcome
        self.mode = config["mode"]
        self.vector = self.mode != "single"
        self.n = int(config["num_envs"]) if self.vector else 1
        self.rng = np.random.default_rng([config["fuzz_seed"], config["index"], 1])
        kwargs = config["kwargs"]
        self.invalid_actions = kwargs.get("invalid_actions", "raise")
        self.same_step = kwargs.get("autoreset_mode") == "SameStep"
        self.phase = "reset"
        self.digest = hashlib.blake2b(digest_size=16)  # what was observed and rewarded
        # Gymnasium's ClipAction clips ±inf to the bounds before the env sees it (NaN
        # passes), and fails on actions that are not numbers: the env's screening of those
        # is not what such a flight tests
        self.clipped = "ClipAction" in config.get("wrappers", ())

    # -- failures

    def fail(self, category: str, message: str) -> None:
        if any(f.category == category for f in self.outcome.failures):
            return
        self.outcome.failures.append(Failure(
            category, self.config["index"], self.config["fuzz_seed"], message,
            phase=self.phase, config=self.config))

    @property
    def failed(self) -> bool:
        return len(self.outcome.failures) >= 3 or any(
            f.category.startswith(("exception", "non_finite")) for f in self.outcome.failures)

    # -- what the episodes should be

    def _scenario(self) -> Any:
        env = self.env.unwrapped.envs[0] if self.mode == "sync" else self.env
        return env.unwrapped.scenario

    def expected_limit(self) -> int:
        steps = self._scenario().steps
        given = self.config["kwargs"].get("max_episode_steps")
        if isinstance(given, bool):  # Gymnasium's TimeLimit takes a flag: True is one step
            given = int(given)
        if isinstance(given, (int, np.integer)) and given >= 1:
            return min(steps, int(given))
        return steps

    def _gymnasium_time_limit(self, truncated: bool, terminated: bool, steps: int) -> bool:
        """Whether an episode ended by a ``TimeLimit`` that Gymnasium wrapped around a
        single env (gym.make, or each env of make_vec's sync mode) at the user's
        ``max_episode_steps``, shorter than the scenario."""
        given = self.config["kwargs"].get("max_episode_steps")
        if isinstance(given, bool):  # Gymnasium's TimeLimit takes a flag: True is one step
            given = int(given)
        return (self.mode in ("single", "sync") and truncated and not terminated
                and isinstance(given, (int, np.integer)) and steps == given
                < self._scenario().steps)

    def check_scenario(self) -> None:
        scenario = self._scenario()
        options = self.config["kwargs"].get("scenario_options", {})
        for name in ("dt", "duration", "substeps", "reference_start_spread", "drag",
                     "motor_lag", "actuation"):
            if name in options and name not in self.config["invalid"]:
                got = getattr(scenario, name, None)
                want = options[name]
                same = (math.isclose(float(got), float(want), rel_tol=1e-12)
                        if isinstance(want, float) else got == want)
                if not same:
                    self.fail("option_ignored", f"scenario_options {name}={want!r} but the "
                                                f"env's scenario has {got!r}")
        if "Residual" in self.config["env_id"]:
            base = getattr(self.env.unwrapped, "base_controller", None)
            if self.mode == "sync":
                base = getattr(self.env.unwrapped.envs[0].unwrapped, "base_controller", None)
            if base is None:
                self.fail("residual_without_base", f"{self.config['env_id']} built an env "
                          "without a base controller (env.unwrapped.base_controller is None)")
        limit = self.expected_limit()
        self.limit = limit
        limits = []
        chains = (self.env.unwrapped.envs if self.mode == "sync" else
                  [] if self.vector else [self.env])
        for chain in chains:
            wrapper = chain
            while hasattr(wrapper, "env"):
                if isinstance(wrapper, gym.wrappers.TimeLimit):
                    limits.append(getattr(wrapper, "_max_episode_steps", None))
                wrapper = wrapper.env
        if self.mode == "vector_entry_point":
            core = getattr(self.env.unwrapped, "core", None)
            limits.append(getattr(core, "episode_steps", None))
        limits = [x for x in limits if isinstance(x, (int, np.integer))]
        if limits and min(limits) < limit:
            self.fail("early_truncation",
                      f"episodes would be truncated after {min(limits)} steps, before the "
                      f"scenario's end at {scenario.steps} steps (dt {scenario.dt}, duration "
                      f"{scenario.duration})"
                      + (f"; the user asked for {limit}" if limit < scenario.steps else ""))
        spec = getattr(self.env.unwrapped, "spec", None)
        reported = getattr(spec, "max_episode_steps", None)
        if reported is not None and reported != limit and limit == scenario.steps:
            self.outcome.notes.append("spec.max_episode_steps differs from the scenario's "
                                      "episode length")

    # -- checks

    def check_obs(self, obs: Any, where: str) -> None:
        space = self.env.observation_space
        if not isinstance(obs, np.ndarray):
            self.fail("bad_observation", f"{where}: observation is a {type(obs).__name__}")
            return
        if obs.dtype.kind == "f" and not np.isfinite(obs).all():
            self.fail("non_finite_observation", f"{where}: non-finite observation entries "
                      f"{np.argwhere(~np.isfinite(obs)).tolist()[:4]}")
        elif not space.contains(obs):
            self.fail("observation_outside_space", f"{where}: observation {obs.dtype} "
                      f"{obs.shape} not in {space}")

    def check_info(self, info: Any, where: str) -> None:
        if not isinstance(info, dict):
            self.fail("bad_info", f"{where}: info is a {type(info).__name__}")
            return
        found = _non_finite(info, "info")
        if found:
            self.fail("non_finite_info", f"{where}: {found} is not finite")

    def check_step(self, reward: Any, terminated: Any, truncated: Any, where: str) -> bool:
        if self.vector:
            ok = all(isinstance(x, np.ndarray) and x.shape == (self.n,)
                     for x in (reward, terminated, truncated))
            if not ok:
                self.fail("bad_step_types", f"{where}: reward/terminated/truncated are not "
                          f"arrays of shape ({self.n},)")
                return False
            if terminated.dtype != bool or truncated.dtype != bool:
                self.fail("bad_step_types", f"{where}: terminated/truncated dtypes "
                          f"{terminated.dtype}, {truncated.dtype}")
            if not np.isfinite(reward).all():
                self.fail("non_finite_reward", f"{where}: reward {reward}")
            return True
        if not isinstance(terminated, (bool, np.bool_)) or not isinstance(truncated,
                                                                          (bool, np.bool_)):
            self.fail("bad_step_types", f"{where}: terminated {type(terminated).__name__}, "
                      f"truncated {type(truncated).__name__}")
        if not isinstance(reward, (int, float, np.floating, np.integer)) or not np.isfinite(
                reward):
            self.fail("non_finite_reward", f"{where}: reward {reward!r}")
        return True

    # -- actions

    def draw_action(self) -> tuple[Any, np.ndarray | None]:
        """An action as passed, and its rows as float64 (None where it is malformed)."""
        plan, rng = self.config["actions"], self.rng
        shape = (self.n, 4) if self.vector else (4,)
        if plan["bad_rate"] and rng.random() < plan["bad_rate"] and not self.clipped:
            bad = [np.zeros(3), np.zeros((self.n + 1, 4)), np.zeros((self.n, 3)),
                   ["a", "b", "c", "d"], None, {"thrust": 1.0}]
            return bad[int(rng.integers(len(bad)))], None
        kind = plan["kind"]
        if kind == "mixed":
            kind = ["uniform", "extremes", "out_of_range", "zeros"][int(rng.integers(4))]
        if kind == "uniform":
            action = rng.uniform(-1, 1, shape)
        elif kind == "extremes":
            action = rng.choice([-1.0, 1.0], shape)
        elif kind == "out_of_range":
            action = rng.uniform(-5, 5, shape)
            if rng.random() < 0.1:
                action.reshape(-1)[int(rng.integers(action.size))] = rng.choice(
                    [1e30, -1e30, 1e308, -1e308, 5e-324])
        else:
            action = np.zeros(shape)
        if plan["nan_rate"]:
            rows = action.reshape(-1, 4)
            for row in np.flatnonzero(rng.random(len(rows)) < plan["nan_rate"]):
                rows[row, int(rng.integers(4))] = rng.choice([NAN, INF, -INF])
        container = plan["container"]
        if container == "float32":
            with np.errstate(over="ignore"):
                action = action.astype(np.float32)
        elif container == "list":
            action = action.tolist()
        rows = np.asarray(action, dtype=np.float64).reshape(-1, 4)
        if self.clipped:
            rows = np.clip(rows, -1.0, 1.0)  # what reaches the env
        return action, rows

    # -- flying

    def fly(self) -> None:
        env, config = self.env, self.config
        obs, info = env.reset(seed=config["seed"])
        self.check_obs(obs, "reset")
        self.check_info(info, "reset")
        self.phase = "checks"
        self.check_scenario()
        steps = config["steps"]
        if config["to_the_end"] and self.limit + 3 <= 2500:
            steps = max(steps, self.limit + 3)
        if config["kwargs"].get("render_mode") == "rgb_array":
            env.render()
        self.phase = "step"
        count = np.zeros(self.n, dtype=np.int64)  # steps of the current episodes
        pending = np.zeros(self.n, dtype=bool)  # next-step autoreset: reset by this step
        counting = True  # False once a single env was stepped past its end without reset
        for step in range(steps):
            if self.failed:
                return
            action, rows = self.draw_action()
            active = ~pending
            bad_rows = (~np.isfinite(rows).all(axis=1)) if rows is not None else None
            expect_refusal = rows is None or (self.invalid_actions == "raise"
                                              and bool((bad_rows & active).any()))
            where = f"step {step}"
            try:
                obs, reward, terminated, truncated, info = env.step(action)
            except ValueError as exc:
                # (a native vector env may screen the rows of vehicles it resets this step)
                if not (expect_refusal or (self.invalid_actions == "raise"
                                           and bad_rows is not None and bad_rows.any())):
                    raise
                if not str(exc).strip():
                    self.fail("exception:ValueError", f"{where}: a ValueError without a "
                              f"message for an invalid action")
                self.outcome.actions_refused += 1
                if self.mode == "sync":  # the sub-envs before the bad one did step
                    env.reset()
                    count[:] = 0
                    pending[:] = False
                continue
            self.outcome.step_calls += 1
            if expect_refusal and not self.failed:
                self.fail("invalid_action_not_refused", f"{where}: action {action!r:.120} "
                          "was flown; expected a ValueError")
            if not self.check_step(reward, terminated, truncated, where):
                return
            self.check_obs(obs, where)
            self.digest.update(np.ascontiguousarray(obs).tobytes())
            self.digest.update(np.ascontiguousarray(reward, dtype=np.float64).tobytes())
            self.check_info(info, where)
            terminated = np.atleast_1d(np.asarray(terminated, dtype=bool))
            truncated = np.atleast_1d(np.asarray(truncated, dtype=bool))
            ended = terminated | truncated
            self.outcome.vehicle_steps += int(active.sum())
            count[active] += 1
            count[pending] = 0
            for i in np.flatnonzero(ended & ~active):
                self.fail("reset_step_ended", f"{where}: vehicle {i} ended on its reset step")
            reasons = self._reasons(info, ended)
            for i in np.flatnonzero(ended & active if counting else np.zeros(self.n, bool)):
                reason = reasons[i]
                if reason is None and self._gymnasium_time_limit(truncated[i], terminated[i],
                                                                 count[i]):
                    # Gymnasium's TimeLimit (gym.make's max_episode_steps) sets truncated
                    # and leaves info alone; the env cannot see it
                    # (docs/getting-started.md, "Use it")
                    self.outcome.reasons["time_limit (Gymnasium's TimeLimit)"] += 1
                elif reason is None:
                    self.fail("missing_termination_reason",
                              f"{where}: vehicle {i} ended (terminated {terminated[i]}, "
                              f"truncated {truncated[i]}) after {count[i]} steps with no "
                              "info['termination_reason']")
                else:
                    self.outcome.reasons[reason] += 1
                    if reason not in REASONS:
                        self.fail("unknown_reason", f"{where}: reason {reason!r}")
                    elif terminated[i] == (reason == "time_limit"):
                        self.fail("reason_mismatch", f"{where}: terminated {terminated[i]}, "
                                  f"truncated {truncated[i]}, reason {reason!r}")
                if counting and truncated[i] and not terminated[i] and count[i] < self.limit:
                    self.fail("early_truncation",
                              f"{where}: vehicle {i} truncated after {count[i]} steps; its "
                              f"episode lasts {self.limit} steps")
            if counting:
                for i in np.flatnonzero(active & ~ended & (count >= self.limit)):
                    self.fail("late_truncation", f"{where}: vehicle {i} not truncated "
                              f"after {count[i]} steps; its episode lasts {self.limit}")
            if counting and bad_rows is not None and self.invalid_actions == "terminate":
                for i in np.flatnonzero(bad_rows & active):
                    if not (terminated[i] and reasons[i] == "invalid_action"):
                        self.fail("invalid_action_not_ended",
                                  f"{where}: vehicle {i} flew a non-finite action: "
                                  f"terminated {terminated[i]}, reason {reasons[i]!r}")
            if self.vector:
                if self.same_step:
                    count[ended] = 0
                    pending[:] = False
                else:
                    pending = ended & active
            elif ended[0]:
                if config["reset_after_end"]:
                    obs, info = env.reset()
                    self.check_obs(obs, f"reset after {where}")
                    self.check_info(info, f"reset after {where}")
                    count[:] = 0
                    counting = True
                else:
                    counting = False

    def _reasons(self, info: dict, ended: np.ndarray) -> list[str | None]:
        """Each vehicle's ``termination_reason`` this step, None where there is none (in
        same-step autoreset it may sit in ``final_info``)."""
        if not self.vector:
            reason = info.get("termination_reason") or None
            if reason is not None and not ended[0]:
                self.fail("spurious_termination_reason", f"the episode did not end but has "
                          f"reason {reason!r}")
            return [reason]
        top, final = self._reason_rows(info), [None] * self.n
        if isinstance(info.get("final_info"), dict):
            final = self._reason_rows(info["final_info"])
        for i in np.flatnonzero(~ended):
            if top[i] is not None:
                self.fail("spurious_termination_reason", f"vehicle {i} did not end but has "
                          f"reason {top[i]!r}")
        return [a if a is not None else b for a, b in zip(top, final, strict=True)]

    def _reason_rows(self, info: dict) -> list[str | None]:
        values, mask = info.get("termination_reason"), info.get("_termination_reason")
        if values is None:
            return [None] * self.n
        return [str(values[i]) if (mask is None or mask[i]) and values[i] else None
                for i in range(self.n)]


@contextlib.contextmanager
def _time_limit(seconds: float | None):
    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum, frame):
        raise FuzzTimeout(f"configuration ran past {seconds:.0f} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_config(config: dict[str, Any], time_limit: float | None = 120.0,
               keep_traceback: bool = False, make: Any = None) -> Outcome:
    """Build (with ``make(config)``, default ``build``), reset and fly one configuration in
    this process; what happened."""
    make = make or build
    outcome = Outcome(config["index"], mode=config["mode"])
    start = time.perf_counter()
    flight = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with _time_limit(time_limit):
                env = make(config)
                outcome.built = True
                flight = _Flight(config, env, outcome)
                flight.fly()
                flight.phase = "close"
                env.close()
                if config["replay"] and not outcome.failures:
                    flight.phase = "replay"
                    again = _Flight(config, make(config), Outcome(config["index"]))
                    again.fly()
                    again.env.close()
                    if again.digest.digest() != flight.digest.digest():
                        flight.fail("nondeterministic", "the same configuration and seed, "
                                    "built and flown again, observed or rewarded otherwise")
        except (Exception, FuzzTimeout) as exc:
            phase = "build" if flight is None else flight.phase
            if phase in ("build", "reset") and _clear_error(exc):
                outcome.status, outcome.refusal = "refused", str(exc)
                outcome.built = False
                if phase == "reset":
                    outcome.notes.append("refused at the first reset, not when built")
            elif (phase == "build" and config["upstream_invalid"]
                  and _raised_by_gymnasium(exc)):
                outcome.status, outcome.refusal = "upstream", _last_line(exc)
            else:
                category = ("timeout" if isinstance(exc, FuzzTimeout)
                            else "memory_not_refused" if isinstance(exc, MemoryError)
                            else f"exception:{type(exc).__name__}")
                outcome.failures.append(Failure(
                    category, config["index"], config["fuzz_seed"], _last_line(exc),
                    _where(exc), phase, config,
                    "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
                    if keep_traceback else ""))
    for item in caught:
        if _in_repository(item.filename) or "gymnasium" in item.filename:
            where = os.path.relpath(item.filename, ROOT) if _in_repository(item.filename) \
                else "gymnasium"
            outcome.warnings.append(f"{item.category.__name__} at {where}:{item.lineno}: "
                                    f"{str(item.message)[:100]}")
    if outcome.failures and outcome.status == "built":
        outcome.status = "failed"
    if outcome.status == "built" and config["memory_hungry"]:
        outcome.failures.append(Failure(
            "memory_not_refused", config["index"], config["fuzz_seed"],
            "a request over the memory budget was built", phase="build", config=config))
        outcome.status = "failed"
    if outcome.status == "refused" and config["memory_hungry"] and \
            "memory" not in outcome.refusal:
        outcome.notes.append("a huge request was refused, without naming the memory budget")
    outcome.wall = time.perf_counter() - start
    return outcome


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ISOLATED_MEMORY_LIMIT, ISOLATED_MEMORY_LIMIT))


def run_isolated(config: dict[str, Any], timeout: float | None = ISOLATED_TIMEOUT) -> Outcome:
    """``run_config`` in a child process with an address-space limit and a timeout (None: no
    judgement by the clock, only a stop for a child that hangs)."""
    start = time.perf_counter()
    stop = HANG_STOP if timeout is None else timeout + 10
    command = [sys.executable, str(Path(__file__).resolve()), "--seed",
               str(config["fuzz_seed"]), "--only", str(config["index"]), "--json",
               "--in-process"]
    try:
        done = subprocess.run(command, capture_output=True, text=True, preexec_fn=_limit_memory,
                              timeout=stop, check=False)
    except subprocess.TimeoutExpired:
        done = None
    wall = time.perf_counter() - start
    lines = done.stdout.strip().splitlines() if done is not None else []
    if done is not None and lines and lines[-1].startswith("{"):
        outcome = Outcome.from_json(json.loads(lines[-1]))
    else:
        outcome = Outcome(config["index"], status="failed", mode=config["mode"])
        why = (f"no answer within {stop:.0f} s" if done is None else
               f"the child exited {done.returncode}: "
               + (done.stderr.strip().splitlines() or [""])[-1][:300])
        outcome.failures.append(Failure(
            "memory_not_refused" if config["memory_hungry"] else "exception:child_died",
            config["index"], config["fuzz_seed"], why, phase="build", config=config))
    outcome.isolated = True
    if timeout is not None and outcome.wall > timeout and not outcome.failures:
        outcome.failures.append(Failure(
            "memory_not_refused" if config["memory_hungry"] else "timeout", config["index"],
            config["fuzz_seed"], f"took {outcome.wall:.0f} s", phase="build", config=config))
        outcome.status = "failed"
    outcome.wall = wall
    return outcome


def _needs_isolation(config: dict[str, Any]) -> bool:
    return config["memory_hungry"] or bool(config["huge"])


def fuzz(count: int, seed: int = 0, *, time_limit: float | None = 120.0,
         isolated_timeout: float | None = ISOLATED_TIMEOUT, isolate: bool = True,
         progress: bool = False) -> FuzzReport:
    """Try ``count`` configurations of run ``seed``; the figures and every failure.
    ``time_limit`` (a configuration) and ``isolated_timeout`` (a huge request's refusal):
    seconds, or None to judge nothing by the clock (the test suite's profile)."""
    report = FuzzReport(seed)
    start = time.perf_counter()
    for index in range(count):
        config = draw_config(seed, index)
        if isolate and _needs_isolation(config):
            outcome = run_isolated(config, isolated_timeout)
        else:
            outcome = run_config(config, time_limit)
        report.add(outcome, config)
        if progress and (index + 1) % 50 == 0:
            print(f"  {index + 1}/{count} configurations, {len(report.failures)} failures, "
                  f"{time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    report.wall = time.perf_counter() - start
    return report


# ---------------------------------------------------------------------------------------
# a reproduction to read


def _literal(value: Any) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return f"float({str(value)!r})"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k!r}: {_literal(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        inner = ", ".join(_literal(v) for v in value)
        if isinstance(value, list):
            return f"[{inner}]"
        return f"({inner},)" if len(value) == 1 else f"({inner})"
    return repr(value)


def repro_code(config: dict[str, Any]) -> str:
    """A few lines of Python that build the configuration's env and fly random actions."""
    kwargs = dict(config["kwargs"])
    args = "".join(f", {k}={_literal(v)}" for k, v in kwargs.items())
    if config["mode"] == "single":
        make = f"env = gym.make({config['env_id']!r}{args})"
        shape = "4"
    else:
        make = (f"env = gym.make_vec({config['env_id']!r}, num_envs={config['num_envs']!r}, "
                f"vectorization_mode={config['mode']!r}{args})")
        shape = f"({config['num_envs']}, 4)"
    if config["mode"] == "sync" and "autoreset_mode" in kwargs:
        make = make.replace(f", autoreset_mode={kwargs['autoreset_mode']!r}",
                            f", vector_kwargs={{'autoreset_mode': "
                            f"AutoresetMode({kwargs['autoreset_mode']!r})}}")
    elif "autoreset_mode" in kwargs:
        make = make.replace(f"autoreset_mode={kwargs['autoreset_mode']!r}",
                            f"autoreset_mode=AutoresetMode({kwargs['autoreset_mode']!r})")
    wrapped = [f"env = gym.wrappers{'' if config['mode'] == 'single' else '.vector'}.{name}(env)"
               for name in config.get("wrappers", ())]
    return "\n".join([
        "import gymnasium as gym, numpy as np",
        "from gymnasium.vector import AutoresetMode",
        "import quad_dob_env",
        make,
        *wrapped,
        f"obs, info = env.reset(seed={config['seed']})",
        "rng = np.random.default_rng(0)",
        f"for _ in range({config['steps']}):",
        f"    obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, {shape}))",
    ])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--configs", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", type=int, default=None, help="run configuration K alone")
    parser.add_argument("--json", action="store_true", help="with --only: the outcome as JSON")
    parser.add_argument("--in-process", action="store_true",
                        help="with --only: do not isolate a huge request in a child")
    parser.add_argument("--time-limit", type=float, default=120.0,
                        help="seconds a configuration may take")
    args = parser.parse_args(argv)
    if args.only is not None:
        config = draw_config(args.seed, args.only)
        if args.json:
            outcome = run_config(config, ISOLATED_TIMEOUT if args.in_process else None)
            print(json.dumps(outcome.to_json(), default=str))
            return 0
        print(_short(config))
        print("invalid options:", config["invalid"], "huge:", config["huge"],
              "memory-hungry:", config["memory_hungry"])
        print("--- reproduction\n" + repro_code(config) + "\n---")
        outcome = (run_isolated(config) if _needs_isolation(config) and not args.in_process
                   else run_config(config, args.time_limit, keep_traceback=True))
        print(f"status: {outcome.status}; {outcome.step_calls} steps; reasons "
              f"{dict(outcome.reasons)}; {outcome.wall:.2f} s")
        if outcome.refusal:
            print("refusal:", outcome.refusal)
        for failure in outcome.failures:
            print(failure.describe())
            if failure.traceback:
                print(failure.traceback)
        return 1 if outcome.failures else 0
    report = fuzz(args.configs, args.seed, time_limit=args.time_limit, progress=True)
    print(report.summary())
    return 1 if report.failures else 0


if __name__ == "__main__":
    sys.exit(main())
