"""``check_controller``: what a user's controller gets wrong against the ``Controller``
interface, found by building it and flying it as the benchmark will, before any table does.

Each check answers one thing the envs and ``quad-dob`` rely on:

- it builds from its name with its declared ``tunable_gains`` (each also at 1.5 times its
  default, as the tuning will try), and refuses a gain it does not have;
- ``compute`` returns thrust (N,) and moment (N, 3), finite, for a batch, without writing
  into the state or reference it was given;
- each vehicle's command depends on that vehicle alone (a vehicle flown in a batch of three
  flies as it does alone, to 1e-9 m), so a mean over the batch or a wrong axis shows;
- ``reset`` of one vehicle leaves the others' commands as they were;
- in a calm v2 hover (sensing, latency, motors) every vehicle stays within
  ``HOVER_TOLERANCE`` of its reference, and none ends its flight early.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from quad_dob_baselines import Controller, make_controller, plugins
from quad_dob_composition.envs import make_vector_env
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario

HOVER_TOLERANCE = 0.2  # [m] the largest position error a working controller shows in calm hover
CHECK_SCENARIO = "hover-calm"
BATCH_SEEDS = (11, 12, 13)
CHECKED_STEPS = 300  # 3 s at 100 Hz: the start transient and the settled hover


def check_controller(controller: str | Any, vehicle: str = "paper",
                     benchmark: str = "v2") -> list[str]:
    """Every problem found with ``controller`` (a name such as ``py:pkg.mod:Name``, or the
    class or factory itself), each a sentence saying what is wrong and what the interface
    wants; empty when it passes every check (module docstring)."""
    params = get_vehicle(vehicle)
    spec = controller if isinstance(controller, str) else getattr(
        controller, "__qualname__", repr(controller))
    try:
        build = _builder(controller, spec, params, benchmark)
        build({})
    except Exception as error:  # the user's code may raise anything: report, go no further
        return [f"{spec} cannot be built: {error}"]
    problems = _gain_problems(controller, spec, build)
    scenario = make_scenario(CHECK_SCENARIO, benchmark=benchmark, vehicle=params.name)
    interface = _command_problems(build, spec, scenario)
    if interface:
        return problems + interface  # flying a broken interface would only raise
    return problems + _flight_problems(build, spec, scenario)


def _builder(controller: str | Any, spec: str, params: Any, benchmark: str
             ) -> Callable[[dict], Controller]:
    if isinstance(controller, str):
        return lambda gains: make_controller(controller, params, benchmark, **gains)
    factory = plugins.as_factory(controller, spec)
    return lambda gains: plugins.built_controller(factory, spec, params, gains)


def _gain_problems(controller: str | Any, spec: str,
                   build: Callable[[dict], Controller]) -> list[str]:
    found = controller
    if isinstance(controller, str):
        user = plugins.resolve(controller, {})
        found = user[1] if user is not None else None
    if found is None:
        return []
    try:
        gains, _ = plugins.declared_gains(found, spec)
    except ValueError as error:
        return [str(error)]
    problems = []
    for key, value in gains.items():
        try:
            build({key: value * 1.5})
        except Exception as error:
            problems.append(f"{spec} declares tunable gain {key!r} but cannot be built with "
                            f"{key}={value * 1.5:g}: {error}")
    try:
        build({"not_a_gain": 1.0})
        problems.append(f"{spec} was built with a gain it does not have (not_a_gain=1.0): a "
                        "misspelt gain would be silently ignored; take the gains by name and "
                        "raise on an unknown one")
    except Exception:  # refused, as it should be
        pass
    return problems


def _first_states(scenario: Any, seeds: tuple[int, ...]) -> tuple[Any, Any]:
    """A batch core at its first step, flown by the recommended base (only its readings and
    reference are used)."""
    env = make_vector_env(len(seeds), scenario, base_controller="geometric")
    env.reset(seed=list(seeds))
    return env.core, env


def _command_problems(build: Callable[[dict], Controller], spec: str, scenario: Any
                      ) -> list[str]:
    core, _ = _first_states(scenario, BATCH_SEEDS)
    n = len(BATCH_SEEDS)
    state, reference = core.measurement.copy(), core.reference
    before = state.copy()
    before_reference = {field.name: getattr(reference, field.name).copy()
                        for field in dataclasses.fields(reference)}
    controller = build({})
    try:
        controller.reset(n, core.vehicle, scenario.dt, actuation=scenario.actuation)
        result = controller.compute(core.time.copy(), state, reference)
    except Exception as error:
        return [f"{spec}: reset then compute on a batch of {n} raised "
                f"{type(error).__name__}: {error}"]
    if not (isinstance(result, tuple) and len(result) == 2):
        return [f"{spec}: compute must return (thrust (N,), moment (N, 3)), got "
                f"{type(result).__name__}"]
    thrust, moment = (np.asarray(part) for part in result)
    problems = []
    if thrust.shape != (n,) or moment.shape != (n, 3):
        problems.append(f"{spec}: compute returned thrust {thrust.shape} and moment "
                        f"{moment.shape} for {n} vehicles; the interface wants ({n},) and "
                        f"({n}, 3)")
    elif not (np.all(np.isfinite(thrust)) and np.all(np.isfinite(moment))):
        problems.append(f"{spec}: compute returned a NaN or infinite command at hover")
    for name in ("position", "velocity", "rotation", "angular_velocity"):
        if not np.array_equal(getattr(state, name), getattr(before, name)):
            problems.append(f"{spec}: compute wrote into state.{name}; the state is the "
                            "env's, shared with the rest of the step: copy before changing")
    for name, value in before_reference.items():
        if not np.array_equal(getattr(reference, name), value):
            problems.append(f"{spec}: compute wrote into reference.{name}; copy it first")
    if problems:
        return problems
    try:
        controller.applied(state, thrust, moment)
        controller.reset(n, core.vehicle, scenario.dt, indices=np.array([1]),
                         actuation=scenario.actuation)
    except Exception as error:
        return [f"{spec}: applied, or reset of one vehicle, raised "
                f"{type(error).__name__}: {error}"]
    return problems


def _flight_problems(build: Callable[[dict], Controller], spec: str, scenario: Any
                     ) -> list[str]:
    batch = _fly(build({}), scenario, BATCH_SEEDS)
    alone = _fly(build({}), scenario, BATCH_SEEDS[1:2])
    problems = []
    if isinstance(batch, str) or isinstance(alone, str):
        return [next(result for result in (batch, alone) if isinstance(result, str))]
    positions, errors, ended, reasons = batch
    steps = min(len(positions), len(alone[0]))
    gap = float(np.max(np.abs(positions[:steps, 1] - alone[0][:steps, 0])))
    if gap > 1e-9:
        problems.append(f"{spec}: vehicle 2 of a batch of {len(BATCH_SEEDS)} flew up to "
                        f"{gap:.3g} m away from the same vehicle flown alone: a vehicle's "
                        "command must depend on its own rows only (a mean or sum over the "
                        "batch, or an axis mixed up, does this)")
    if ended.any():
        problems.append(f"{spec}: in a calm hover ({CHECK_SCENARIO}, benchmark "
                        f"{scenario.benchmark}) {int(ended.sum())} of {len(ended)} flights "
                        f"ended early ({', '.join(sorted(set(reasons)))})")
    elif errors.max() > HOVER_TOLERANCE:
        problems.append(f"{spec}: in a calm hover ({CHECK_SCENARIO}, benchmark "
                        f"{scenario.benchmark}) a vehicle strayed {errors.max():.3f} m from "
                        f"its reference (a working controller stays within "
                        f"{HOVER_TOLERANCE} m)")
    return problems


def _fly(controller: Controller, scenario: Any, seeds: tuple[int, ...]
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]] | str:
    """Positions (steps, N, 3), each vehicle's largest error, which ended early and why, for
    ``CHECKED_STEPS`` steps with ``controller`` as a residual env's base, residual zero."""
    try:
        env = make_vector_env(len(seeds), scenario, base_controller=controller)
        env.reset(seed=list(seeds))
        core = env.core
        positions, largest = [], np.zeros(len(seeds))
        ended, reasons = np.zeros(len(seeds), dtype=bool), []
        for _ in range(min(CHECKED_STEPS, scenario.steps)):
            error = np.linalg.norm(core.state.position - core.reference.position, axis=1)
            largest = np.maximum(largest, np.where(ended, 0.0, error))
            positions.append(core.state.position.copy())
            _, _, terminated, truncated, _ = env.step(np.zeros((len(seeds), 4)))
            stopped = (terminated | truncated) & ~ended
            reasons += [core.termination_reason(int(i)) or "time limit"
                        for i in np.flatnonzero(stopped)]
            ended |= terminated
    except Exception as error:
        return (f"{controller.name}: flying {CHECK_SCENARIO} raised "
                f"{type(error).__name__}: {error}")
    return np.array(positions), largest, ended, reasons
