"""A stable-baselines3 ``VecEnv`` over the native batched core, for PPO on N vehicles.

SB3 does not take Gymnasium vector envs, and its convention differs: an episode that ends
is reset in the same step, the returned observation is the new episode's first, and the
last one goes in ``infos[i]["terminal_observation"]`` (``"TimeLimit.truncated"`` says
whether it was the time limit). This adapter drives a ``QuadrotorVectorEnv``'s core that
way, so ``PPO("MlpPolicy", QuadrotorSB3VecEnv(...))`` trains on N vehicles in one process.

``loop_randomization`` randomises what one batch cannot vary per vehicle, the vehicle loop
(sensing preset, extra latency, motor time constant), the airframe, where the spec gives
them the scenarios the groups fly (``scenario``, cycled with the sensing and airframe
lists), the control rate (``control_rate``, cycled with them: groups at different rates
share one policy, whose reward and γ stay per step) and the scenario's wind scale
(``wind_scale``: the ceiling of its per-vehicle wind draw, for scenarios that take one), by
splitting the N vehicles into ``groups``, each a vector env of its own loop, drawn from the
ranges given (``draw_loops``); mass, inertia, drag, thrust coefficient and wind are drawn
per vehicle by the scenario. It is a training option only: ``env_options`` drops it, so
evaluation flies the named loop. rl-zoo3, which hands ``env_kwargs`` to ``gym.make`` for
each single env, takes it as an ``env_wrapper`` (``loop_randomization.LoopRandomization``)
drawn from the same functions here.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from stable_baselines3.common.vec_env import VecEnv

from quad_dob_composition import ResidualVectorEnv, make_vector_env
from quad_dob_env.benchmark import v3_loop
from quad_dob_env.benchmark_v3 import REAL_LOOPS, TUNING_MARGIN
from quad_dob_env.benchmark_v4 import V4_LOOPS
from quad_dob_env.envs import QuadrotorVectorEnv
from quad_dob_env.params import VEHICLES, get_vehicle
from quad_dob_env.residual import ResidualOptions, ResidualQuadrotorVectorEnv
from quad_dob_env.scenarios import SCENARIOS, make_scenario
from quad_dob_env.sensing import SENSING_PRESETS
from quad_dob_env.validation import checked_keywords, unknown_name_error

# Benchmark v3's uncertain quantities a training loop may draw per group (low, high), each
# drawn only when asked for: pose latency the estimator does not know [s], the rotors' PX4
# thrust-model factor κ, the raw accelerometer vibration [m/s² RMS, before the filter], and
# the battery: the true hover throttle at the start and its drift [1/s]
# (quad_dob_env.benchmark_v3 holds the nominal values and their sources)
V3_LOOP_RANGES = ("unmodelled_pose_latency", "thrust_model_factor", "accelerometer_vibration",
                  "hover_throttle", "hover_throttle_drift")
# the keys of ``loop_randomization``: the number of groups, the sensing presets and the
# vehicles they cycle through, and (low, high) ranges of the scenario options drawn per group
LOOP_RANDOMIZATION_KEYS = ("groups", "sensing", "vehicle", "scenario", "control_rate",
                           "extra_latency", "motor_time_constant_scale", "wind_scale",
                           *V3_LOOP_RANGES, "margin_groups", "supervisor_in_training")
TRAINING_ONLY_KEYS = ("loop_randomization",)
# training-only keys that were removed (docs/research/removed-experiments.md): configs of runs
# trained with them still load for evaluation, which never took them
REMOVED_TRAINING_KEYS = ("termination_penalty",)
# where a drawn loop names the scenario its group flies instead of the env's (not an option
# of the scenario: ``QuadrotorSB3VecEnv`` takes it out)
SCENARIO_KEY = "scenario"
# where a drawn loop trains without the residual's supervisor (``supervisor_in_training:
# false``): a faded residual changes nothing and pays nothing, so PPO gets no gradient from
# the steps it fades, and a policy that drifts to its bounds is faded out of its own
# training (docs/residual-v4.md). The run's config keeps the supervisor, so evaluation and
# every client that flies the model fly it supervised. Not a scenario option either.
SUPERVISOR_KEY = "supervisor_in_training"
# the loop a gain set and a residual must hold (benchmark_v3.TUNING_MARGIN: 20 ms of pose
# latency the estimator does not know, motors 1.5 times slower): ``margin_groups`` groups
# fly at or beyond it, at the slowest rate listed
MARGIN_CORNER = dict(TUNING_MARGIN)


def env_options(env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``env_kwargs`` without the options that only shape training (``loop_randomization``):
    what builds the env a model flies in evaluation."""
    return {key: value for key, value in env_kwargs.items()
            if key not in TRAINING_ONLY_KEYS + REMOVED_TRAINING_KEYS}


def draw_loops(spec: dict[str, Any], seed: int | None, dt: float) -> list[dict[str, Any]]:
    """One scenario-options dict per group: group g takes ``sensing[g % len]``,
    ``vehicle[g % len]``, ``scenario[g % len]`` (under ``SCENARIO_KEY``) and
    ``control_rate[g % len]`` [Hz] (as the scenario's ``dt``) where given (the env's own
    where not; the lists cycle together, so their tuples are the ones listed, not every
    combination), and each range is stratified over the groups (each group draws from its
    own slice of it, the slices shuffled), so a few groups still span it; latencies are
    drawn on each group's control grid (multiples of its ``dt``, the env's ``dt`` without
    ``control_rate``), where the loop resolves them anyway. ``margin_groups`` = M: the
    first M groups at the slowest rate listed draw their motor scale and unmodelled pose
    latency again, between ``MARGIN_CORNER``'s values and the ranges' tops, so every run
    flies the margin's corner however the strata fall. ``supervisor_in_training: false``
    marks every group to train without the residual's supervisor (``SUPERVISOR_KEY``)."""
    for key in spec:
        if key not in LOOP_RANDOMIZATION_KEYS:
            raise unknown_name_error("loop_randomization key", key, LOOP_RANDOMIZATION_KEYS)
    groups = int(spec.get("groups", 4))
    if groups < 1:
        raise ValueError(f"loop_randomization groups must be >= 1, got {groups}")
    sensing, vehicles = list(spec.get("sensing", [])), list(spec.get("vehicle", []))
    scenarios = list(spec.get("scenario", []))
    for key, names in (("sensing", sensing), ("vehicle", vehicles), ("scenario", scenarios)):
        if key in spec and not names:
            raise ValueError(f"loop_randomization {key} must name one or more, got an empty "
                             "list (leave it out to fly the scenario's own)")
    for name in sensing:
        if name not in SENSING_PRESETS:
            raise unknown_name_error("loop_randomization sensing preset", name, SENSING_PRESETS)
    for name in vehicles:
        if name not in VEHICLES:
            raise unknown_name_error("loop_randomization vehicle", name, VEHICLES)
    for name in scenarios:
        if name not in SCENARIOS:
            raise unknown_name_error("loop_randomization scenario", name, SCENARIOS)
    supervised = spec.get(SUPERVISOR_KEY, True)
    if not isinstance(supervised, bool):
        raise ValueError(f"loop_randomization {SUPERVISOR_KEY} must be true or false, got "
                         f"{supervised!r}")
    rates = list(spec.get("control_rate", []))
    if "control_rate" in spec and not rates:
        raise ValueError("loop_randomization control_rate must list one or more rates [Hz], "
                         "got an empty list (leave it out to fly the scenario's own)")
    for rate in rates:
        if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not rate > 0:
            raise ValueError(f"loop_randomization control_rate lists rates in Hz > 0, got "
                             f"{rate!r}")
    clocks = [1.0 / float(rates[g % len(rates)]) if rates else dt for g in range(groups)]
    margin_groups = spec.get("margin_groups", 0)
    slowest = [g for g in range(groups) if clocks[g] == max(clocks)]
    if (isinstance(margin_groups, bool) or not isinstance(margin_groups, int)
            or not 0 <= margin_groups <= len(slowest)):
        raise ValueError(f"loop_randomization margin_groups must be a whole number from 0 to "
                         f"{len(slowest)} (the groups at the slowest rate), got "
                         f"{margin_groups!r}")
    ranges = {}
    for key, default in (("extra_latency", (0.0, 0.0)), ("motor_time_constant_scale", (1.0, 1.0)),
                         ("wind_scale", (1.0, 1.0))):
        value = spec.get(key, default)
        low, high = (float(v) for v in value)
        if not 0.0 <= low <= high or (key == "motor_time_constant_scale" and low == 0.0):
            raise ValueError(f"loop_randomization {key} must be a range 0 <= low <= high "
                             f"(a positive low for the motor scale), got {value!r}")
        ranges[key] = (low, high)
    rng = np.random.default_rng([0 if seed is None else seed, 0x100B])

    def stratified() -> NDArray[np.float64]:  # one draw per group in [0, 1), slice g of g
        return (rng.permutation(groups) + rng.uniform(size=groups)) / groups

    low, high = ranges["extra_latency"]
    where = stratified()
    latency = np.empty(groups)
    for g, clock in enumerate(clocks):  # each group on its own control grid
        grid = clock * np.arange(math.ceil(low / clock - 1e-9),
                                 math.floor(high / clock + 1e-9) + 1)
        if grid.size == 0:
            raise ValueError(f"loop_randomization extra_latency {ranges['extra_latency']} "
                             f"holds no multiple of the control step {clock:g} s")
        latency[g] = grid[min(int(where[g] * grid.size), grid.size - 1)]
    low, high = ranges["motor_time_constant_scale"]
    motor = low + (high - low) * stratified()
    # drawn last, and only when asked for, so specs without it draw as they did before it
    low, high = ranges["wind_scale"]
    wind = low + (high - low) * stratified() if "wind_scale" in spec else None
    # v3's quantities after it, each only when asked for; the battery's two are ranges
    # themselves (each group flies a slice of the spread, drawn per episode within it)
    v3: list[dict[str, Any]] = [{} for _ in range(groups)]
    for key in V3_LOOP_RANGES:
        if key not in spec:
            continue
        low, high = (float(v) for v in spec[key])
        if not 0.0 <= low <= high:
            raise ValueError(f"loop_randomization {key} must be a range 0 <= low <= high, "
                             f"got {spec[key]!r}")
        if key in ("hover_throttle", "hover_throttle_drift"):
            edges = np.linspace(low, high, groups + 1)
            order = rng.permutation(groups)
            for g in range(groups):
                v3[g][key] = [round(float(edges[order[g]]), 6),
                              round(float(edges[order[g] + 1]), 6)]
        else:
            draws = low + (high - low) * stratified()
            for g in range(groups):
                v3[g][key] = round(float(draws[g]), 6)
    # the margin's corner last, only when asked for, so specs without it draw as before
    for g in slowest[:margin_groups]:
        for key, corner in MARGIN_CORNER.items():
            top = max(float((spec.get(key) or (corner, corner))[1]), corner)
            value = corner + (top - corner) * rng.uniform()
            if key == "motor_time_constant_scale":
                motor[g] = value
            else:
                v3[g][key] = round(float(value), 6)
    return [{**({"sensing": sensing[g % len(sensing)]} if sensing else {}),
             "extra_latency": round(float(latency[g]), 6),
             "motor_time_constant_scale": round(float(motor[g]), 4),
             **({"vehicle": vehicles[g % len(vehicles)]} if vehicles else {}),
             **({"wind_scale": round(float(wind[g]), 4)} if wind is not None else {}),
             **({SCENARIO_KEY: scenarios[g % len(scenarios)]} if scenarios else {}),
             **({"dt": clocks[g]} if rates else {}),
             **v3[g],
             **({} if supervised else {SUPERVISOR_KEY: False})}
            for g in range(groups)]


def loop_scenario_options(loop: dict[str, Any], vehicle: str,
                          benchmark: str | None = None) -> dict[str, Any]:
    """A drawn loop as scenario options: v3's thrust-model factor, vibration and battery
    ranges become the throttle map and IMU vibration of ``vehicle``'s v3 loop with those
    values replaced (``benchmark_v3.REAL_LOOPS``; in ``benchmark`` v4 the throttle map is
    v4's, ``benchmark_v4.V4_LOOPS``); the rest are options as they are."""
    options = {key: value for key, value in loop.items()
               if key not in (SCENARIO_KEY, SUPERVISOR_KEY)}
    throttle = {key: options.pop(key) for key in ("thrust_model_factor", "hover_throttle",
                                                  "hover_throttle_drift") if key in options}
    vibration = options.pop("accelerometer_vibration", None)
    if throttle or vibration is not None:
        real = REAL_LOOPS.get(vehicle)
        if real is None:
            raise ValueError(f"loop_randomization's v3 quantities need a vehicle with a v3 "
                             f"loop ({', '.join(REAL_LOOPS)}), got {vehicle!r}")
        if throttle:
            own = V4_LOOPS[vehicle].throttle_map if benchmark == "v4" else real.throttle_map
            options["throttle_map"] = dataclasses.replace(
                own, **{key: tuple(value) if isinstance(value, list) else value
                                      for key, value in throttle.items()})
        if vibration is not None:
            # what the autopilot's filter leaves is linear in the raw level: v3's own
            # filtered level scaled by raw / nominal raw
            gyro, accelerometer = v3_loop(get_vehicle(vehicle), "loop")["imu_vibration"]
            options["imu_vibration"] = (gyro, accelerometer * vibration
                                        / real.accelerometer_vibration)
    return options


def loop_clock(scenario: Any, env_kwargs: dict[str, Any]) -> float:
    """The control step ``draw_loops`` draws latencies on for an env of ``scenario`` built
    with ``env_kwargs``: the scenario's ``dt`` under its options and the env's benchmark."""
    options = dict(env_kwargs.get("scenario_options") or {})
    if env_kwargs.get("benchmark") is not None:
        options.setdefault("benchmark", env_kwargs["benchmark"])
    return make_scenario(scenario, **options).dt


def loop_env_kwargs(loop: dict[str, Any], scenario: Any,
                    env_kwargs: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """The scenario and env keyword arguments that fly one drawn ``loop`` (``draw_loops``)
    in an env of ``scenario`` built with ``env_kwargs``: the loop's scenario where it names
    one, and its options (``loop_scenario_options``, for the loop's vehicle, else the
    env's) laid over the env's ``scenario_options``, and no supervisor where the loop trains
    without one (``SUPERVISOR_KEY``). The vector envs of ``QuadrotorSB3VecEnv``'s groups and
    rl-zoo3's single envs (``loop_randomization.LoopRandomization``) are both built from
    it."""
    vehicle = str((env_kwargs.get("scenario_options") or {}).get("vehicle", "paper"))
    unsupervised = {"supervisor": None} if loop.get(SUPERVISOR_KEY) is False else {}
    return loop.get(SCENARIO_KEY, scenario), {
        **env_kwargs, **unsupervised, "scenario_options": {
            **(env_kwargs.get("scenario_options") or {}),
            **loop_scenario_options(loop, loop.get("vehicle", vehicle),
                                    env_kwargs.get("benchmark"))}}


class QuadrotorSB3VecEnv(VecEnv):
    """``num_envs`` vehicles of ``scenario`` as an SB3 VecEnv; other keyword arguments are
    ``QuadrotorVectorEnv``'s. With ``loop_randomization`` (``draw_loops``) the vehicles are
    split into groups of nearly equal size, each flying its own drawn loop; vehicle i is
    seeded ``seed + i`` either way."""

    @checked_keywords(ResidualVectorEnv.__init__, ResidualQuadrotorVectorEnv.__init__,
                      QuadrotorVectorEnv.__init__, ResidualOptions)
    def __init__(self, num_envs: int, scenario: str = "paper-none", seed: int | None = None,
                 loop_randomization: dict[str, Any] | None = None, **env_kwargs: Any) -> None:
        dt = None  # the clock the latency draws were made on
        if loop_randomization is None:
            self.loops: list[dict[str, Any]] = [{}]
        else:
            dt = loop_clock(scenario, env_kwargs)
            self.loops = draw_loops(loop_randomization, seed, dt)
        if len(self.loops) > num_envs:
            raise ValueError(f"loop_randomization has {len(self.loops)} groups for "
                             f"{num_envs} vehicles: at most one group per vehicle")
        bounds = np.linspace(0, num_envs, len(self.loops) + 1).round().astype(int)
        self.groups = [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds)]
        self.vector_envs = []
        for group, loop in zip(self.groups, self.loops, strict=True):
            flown, kwargs = loop_env_kwargs(loop, scenario, env_kwargs)
            self.vector_envs.append(make_vector_env(group.stop - group.start, flown, **kwargs))
        first = self.vector_envs[0]
        for loop, venv in zip(self.loops, self.vector_envs, strict=True):
            # one policy flies every group: the same spaces, and the clock the latency draws
            # were made on (the group's own rate where control_rate gives one)
            if (venv.single_observation_space != first.single_observation_space
                    or venv.scenario.dt != loop.get("dt", dt or first.scenario.dt)):
                raise ValueError(f"loop group {loop} flies {venv.scenario.name!r} with "
                                 f"dt={venv.scenario.dt:g} and {venv.single_observation_space},"
                                 f" unlike the first group's {first.scenario.name!r}: the "
                                 "groups' scenarios must share the observation space, and "
                                 "dt unless control_rate sets it")
        super().__init__(num_envs, first.single_observation_space, first.single_action_space)
        self._seed = seed
        self._actions: NDArray | None = None

    def reset(self) -> NDArray[np.float32]:
        for group, venv in zip(self.groups, self.vector_envs, strict=True):
            n = group.stop - group.start
            venv.reseed([None if self._seed is None else self._seed + group.start + i
                         for i in range(n)])
            venv.restart(np.arange(n))
        self._seed = None  # later resets continue each vehicle's generator
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return self._observations()

    def _observations(self) -> NDArray[np.float32]:
        if len(self.vector_envs) == 1:
            return self.vector_envs[0].observations()
        return np.concatenate([venv.observations() for venv in self.vector_envs])

    def step_async(self, actions: NDArray) -> None:
        self._actions = actions  # checked by the vector env's fly

    def step_wait(self) -> tuple[NDArray[np.float32], NDArray, NDArray, list[dict]]:
        rewards = np.empty(self.num_envs, np.float32)
        dones = np.empty(self.num_envs, bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for group, venv in zip(self.groups, self.vector_envs, strict=True):
            core = venv.core
            venv.step_vehicles(self._actions[group])
            rewards[group] = venv.rewards()
            terminated, truncated = core.terminated, core.truncated
            dones[group] = terminated | truncated
            ended = np.flatnonzero(dones[group])
            if ended.size:
                last = venv.observations()[ended]
                for j, i in enumerate(ended):
                    infos[group.start + i] = {
                        "terminal_observation": last[j],
                        "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                        "termination_reason": core.termination_reason(i)}
                venv.restart(ended)
        return self._observations(), rewards, dones, infos

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def close(self) -> None:
        for venv in self.vector_envs:
            venv.close()

    def _targets(self, indices: int | Iterable[int] | None) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        return [indices] if isinstance(indices, int) else list(indices)

    def _owner(self, index: int) -> Any:
        """The vector env that flies vehicle ``index``."""
        for group, venv in zip(self.groups, self.vector_envs, strict=True):
            if group.start <= index < group.stop:
                return venv
        raise IndexError(f"vehicle index {index} out of range for {self.num_envs} vehicles")

    def get_attr(self, attr_name: str, indices: int | Iterable[int] | None = None) -> list[Any]:
        """An attribute of the vector env (shared by its vehicles), once per index."""
        return [getattr(self._owner(i), attr_name) for i in self._targets(indices)]

    def set_attr(self, attr_name: str, value: Any,
                 indices: int | Iterable[int] | None = None) -> None:
        raise AttributeError(f"the {self.num_envs} vehicles share their envs; cannot set "
                             f"{attr_name!r} for some of them")

    def env_method(self, method_name: str, *method_args: Any,
                   indices: int | Iterable[int] | None = None, **method_kwargs: Any) -> list:
        return [getattr(self._owner(i), method_name)(*method_args, **method_kwargs)
                for i in self._targets(indices)]

    def env_is_wrapped(self, wrapper_class: type,
                       indices: int | Iterable[int] | None = None) -> list[bool]:
        return [False for _ in self._targets(indices)]
