"""Drawing a configuration: ``draw_config(seed, index)`` and the draws it is made of.

Every configuration is drawn from its own seeded generator,
``numpy.random.default_rng([seed, index])``, as a user could combine things: an env id, maybe
another scenario by name, single env (``gym.make``) or vector env (``gym.make_vec``,
``vector_entry_point`` or ``sync``, 1-8 vehicles); options of the scenario and of the env,
mostly valid, some not (a string where a number goes, None, a negative, NaN, a huge value, an
unknown name); actions in [-1, 1], at the extremes, out of range, sometimes NaN or infinite,
sometimes of the wrong shape or type.

Here: the menus a configuration is drawn from (ids, scenarios, modes, wrappers, bad numbers),
``_Draw`` (one configuration's generator, and the names of the options it drew invalid or
huge), the scenario's and the env's options, the action plan, the requests over the memory
budget (``MEMORY_HUNGRY``), ``draw_config`` itself and ``short_config``, a configuration in
one line. A configuration is a plain dict: what ``flight.build`` makes and flies.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

import quad_dob_env
from quad_dob_env import scenarios as scenario_registry

ENV_IDS = list(quad_dob_env.ENV_IDS)
SCENARIOS = quad_dob_env.list_scenarios()
FAMILIES = ("random-tracks", "random-lemniscates")
# builder options per scenario, as make_scenario reads them
BUILDER_OPTIONS: dict[str, tuple[str, ...]] = dict(
    getattr(scenario_registry, "_BUILDER_OPTIONS", {}))
CONTROLLERS = ("geometric", "geometric-ndob", "geometric-ndob:tuned",
               "geometric-ndob:gains-tuned", "pid", "smc")
MODES = ("single", "vector_entry_point", "sync")
MAX_TABLE_STEPS = 3000  # duration / dt of a drawn configuration (families: half)

# Gymnasium's wrappers a configuration may name (flight.build wraps the env in them)
SINGLE_WRAPPERS = ("TimeAwareObservation", "RecordEpisodeStatistics", "ClipAction",
                   "NormalizeObservation", "FlattenObservation")
VECTOR_WRAPPERS = ("RecordEpisodeStatistics", "ClipAction", "NormalizeObservation")

NAN, INF = float("nan"), float("inf")
# values that no numeric option takes
BAD_NUMBERS: tuple[Any, ...] = ("0.01", None, NAN, INF, -INF, True, [1.0, 2.0], "fast")


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
        dt, float) and 0 < dt < math.inf else 200.0)
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
    return built.actuation, built.loop.drag, built.vehicle.name


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


def short_config(config: dict[str, Any]) -> str:
    """The configuration in one line: what a user would pass, and the actions flown."""
    keep = {k: config[k] for k in ("env_id", "mode", "num_envs", "kwargs", "wrappers",
                                   "actions", "steps", "seed") if k in config}
    return repr(keep)
