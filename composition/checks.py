"""``check_controller``: what a user's controller gets wrong against the ``Controller``
interface, found by building it and flying it as the benchmark will, before any table does.

Each check answers one thing the envs and ``quad-dob`` rely on:

- it builds from its name with its declared ``tunable_gains``; each gain at 1.5 times its
  default builds too (as the tuning will try) and changes the first second of flight (a
  gain that changes nothing would be searched for nothing); a made-up gain is refused;
- ``compute`` returns thrust (N,) and moment (N, 3), finite, for a batch of four, without
  writing into the state or reference it was given (checked on values with no exact zero,
  so that a write which scales or zeroes a field shows);
- ``reset`` of one vehicle leaves the others' next commands as they were;
- each vehicle's command depends on that vehicle alone (a vehicle flown in a batch of four
  flies as it does alone, to 1e-9 m), both with the scenario's inner loop and with one
  controller at the control rate, so a mean over the batch or a wrong axis shows (with an
  inner loop a controller with ``has_inner_law`` flies its ``inner_law()`` between control
  steps: a subclass of a built-in that changes ``compute``'s moment must override
  ``inner_law`` too, or set ``has_inner_law = False``; the second flight is the one that
  flies its ``compute``);
- in a calm v2 hover (sensing, latency, motors) every vehicle stays within
  ``HOVER_TOLERANCE`` of its reference, and none ends its flight early.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from quad_dob_baselines import Controller, make_controller, plugins, user_controller
from quad_dob_composition.envs import make_vector_env
from quad_dob_env.benchmark import TOOLS_BENCHMARK
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario

HOVER_TOLERANCE = 0.2  # [m] the largest position error a working controller shows in calm hover
CHECK_SCENARIO = "hover-calm"
# four, not three: a (3, N) moment of three vehicles would pass for (N, 3)
BATCH_SEEDS = (11, 12, 13, 14)
CHECKED_STEPS = 300  # 3 s at 100 Hz: the start transient and the settled hover
GAIN_STEPS = 100  # 1 s: long enough for any gain to move the flight in gusts and noise
GAIN_SCENARIO = "gusty-hover"


def check_controller(controller: str | Any, vehicle: str = "paper",
                     benchmark: str = TOOLS_BENCHMARK) -> list[str]:
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
    scenario = make_scenario(CHECK_SCENARIO, benchmark=benchmark, vehicle=params.name)
    # one controller at the control rate, compute's command held over the step
    single_rate = make_scenario(CHECK_SCENARIO, benchmark=benchmark, vehicle=params.name,
                                inner_rate=0) if scenario.loop.inner_rate else None
    interface = _command_problems(build, spec, scenario)
    gains = _gain_problems(controller, spec, build, None if interface else make_scenario(
        GAIN_SCENARIO, benchmark=benchmark, vehicle=params.name))
    if interface:
        return gains + interface
    return gains + _flight_problems(build, spec, scenario, single_rate)


def _builder(controller: str | Any, spec: str, params: Any, benchmark: str
             ) -> Callable[[dict], Controller]:
    if isinstance(controller, str):
        return lambda gains: make_controller(controller, params, benchmark, **gains)
    factory = plugins.as_factory(controller, spec)
    return lambda gains: plugins.built_controller(factory, spec, params, gains)


def _gain_problems(controller: str | Any, spec: str, build: Callable[[dict], Controller],
                   scenario: Any | None) -> list[str]:
    """The declared gains: valid, each accepted at 1.5x and (given a ``scenario`` to fly)
    changing the first ``GAIN_STEPS`` of flight; a made-up gain refused."""
    found = controller
    if isinstance(controller, str):
        user = user_controller(controller)
        found = user[1] if user is not None else None
    if found is None:
        return []
    try:
        gains, _ = plugins.declared_gains(found, spec)
    except ValueError as error:
        return [str(error)]
    problems = []
    flown = None if scenario is None else _fly(build({}), scenario, BATCH_SEEDS[:1],
                                               GAIN_STEPS)
    for key, value in gains.items():
        try:
            changed = build({key: value * 1.5})
        except Exception as error:
            problems.append(f"{spec} declares tunable gain {key!r} but cannot be built with "
                            f"{key}={value * 1.5:g}: {error}")
            continue
        if flown is None or isinstance(flown, str):
            continue
        other = _fly(changed, scenario, BATCH_SEEDS[:1], GAIN_STEPS)
        if not isinstance(other, str) and np.array_equal(other[0], flown[0]):
            problems.append(f"{spec} declares tunable gain {key!r}, but {key}={value * 1.5:g} "
                            f"flies the first {GAIN_STEPS} steps exactly as {key}={value:g}: "
                            "the tuning would search a gain that does nothing (is it passed "
                            "on to the law?)")
    try:
        build({"not_a_gain": 1.0})
        problems.append(f"{spec} was built with a gain it does not have (not_a_gain=1.0): a "
                        "misspelt gain would be silently ignored; take the gains by name and "
                        "raise on an unknown one")
    except Exception:  # refused, as it should be
        pass
    return problems


def _first_step(scenario: Any, seeds: tuple[int, ...]) -> Any:
    """A batch env at its first step, flown by the geometric controller (only its core's
    readings and reference are used)."""
    env = make_vector_env(len(seeds), scenario, base_controller="geometric")
    env.reset(seed=list(seeds))
    return env


def _without_zeros(state: Any, reference: Any) -> tuple[Any, Any]:
    """The first step's state and reference with a small, distinct offset on every vector
    field: at the start of a hover the velocities, rates and the reference's derivatives
    are exactly zero, and an in-place write that scales or zeroes them (``state.velocity
    *= 0.5``) would leave them as they were and pass unseen. The rotation keeps its value:
    an offset would make it no rotation, and its non-zero entries show a write anyway."""
    offsets = 1e-3 * (1.0 + np.arange(state.position.size, dtype=float)).reshape(
        state.position.shape)
    for name in ("position", "velocity", "angular_velocity", "gyroscope"):
        if getattr(state, name, None) is not None:
            setattr(state, name, getattr(state, name) + offsets)
    reference = dataclasses.replace(reference, **{
        field.name: getattr(reference, field.name) + offsets
        for field in dataclasses.fields(reference) if field.name != "heading"})
    return state, reference


def _command_problems(build: Callable[[dict], Controller], spec: str, scenario: Any
                      ) -> list[str]:
    core = _first_step(scenario, BATCH_SEEDS).core
    n = len(BATCH_SEEDS)
    state, reference = _without_zeros(core.measurement.copy(), core.reference)
    before = state.copy()
    before_reference = {field.name: getattr(reference, field.name).copy()
                        for field in dataclasses.fields(reference)}
    controller, twin = build({}), build({})
    try:
        for one in (controller, twin):
            one.reset(n, core.vehicle, scenario.dt, actuation=scenario.actuation)
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
    for name in ("position", "velocity", "rotation", "angular_velocity", "gyroscope",
                 "accelerometer", "rotor_speeds"):
        if not np.array_equal(getattr(state, name, None), getattr(before, name, None)):
            problems.append(f"{spec}: compute wrote into state.{name}; the state is the "
                            "env's, shared with the rest of the step: copy before changing")
    for name, value in before_reference.items():
        if not np.array_equal(getattr(reference, name), value):
            problems.append(f"{spec}: compute wrote into reference.{name}; copy it first")
    if problems:
        return problems
    return _reset_problems(controller, twin, spec, core, scenario, state, reference)


def _reset_problems(controller: Controller, twin: Controller, spec: str, core: Any,
                    scenario: Any, state: Any, reference: Any) -> list[str]:
    """Both fly the same first step; ``controller`` then restarts vehicle 2 alone, and the
    others' next commands must be the twin's."""
    n = len(BATCH_SEEDS)
    try:
        twin.compute(core.time.copy(), state.copy(), reference)
        for one in (controller, twin):
            one.applied(state.copy(), np.full(n, core.vehicle.hover_thrust), np.zeros((n, 3)))
        controller.reset(n, core.vehicle, scenario.dt, indices=np.array([1]),
                         actuation=scenario.actuation)
        later = core.time + scenario.dt
        mine = controller.compute(later, state.copy(), reference)
        theirs = twin.compute(later, state.copy(), reference)
    except Exception as error:
        return [f"{spec}: applied, reset of one vehicle, or the next compute raised "
                f"{type(error).__name__}: {error}"]
    others = np.array([0, 2, 3])
    if not (np.allclose(mine[0][others], theirs[0][others], rtol=0, atol=1e-9)
            and np.allclose(np.asarray(mine[1])[others], np.asarray(theirs[1])[others],
                            rtol=0, atol=1e-9)):
        return [f"{spec}: reset(indices=[1]) changed the next command of vehicles 0, 2 and 3 "
                "too: a restart must clear the state of the given rows only"]
    return []


def _flight_problems(build: Callable[[dict], Controller], spec: str, scenario: Any,
                     single_rate: Any | None) -> list[str]:
    """The batch check in the scenario's loop (v2: an inner loop running ``inner_law``) and
    in ``single_rate``, one controller at the control rate; the hover check in the first."""
    problems: list[str] = []
    flights = []
    for flown, where in ((scenario, ""), (single_rate, " without the inner loop")):
        if flown is None:
            continue
        batch = _fly(build({}), flown, BATCH_SEEDS, CHECKED_STEPS)
        alone = _fly(build({}), flown, BATCH_SEEDS[1:2], CHECKED_STEPS)
        failed = [result for result in (batch, alone) if isinstance(result, str)]
        if failed:
            return problems + failed[:1]
        flights.append(batch)
        steps = min(len(batch[0]), len(alone[0]))
        gap = float(np.max(np.abs(batch[0][:steps, 1] - alone[0][:steps, 0])))
        if gap > 1e-9:
            problems.append(f"{spec}: vehicle 2 of a batch of {len(BATCH_SEEDS)} flew up to "
                            f"{gap:.3g} m away from the same vehicle flown alone{where}: a "
                            "vehicle's command must depend on its own rows only (a mean or "
                            "sum over the batch, or an axis mixed up, does this)")
    _, errors, ended, reasons = flights[0]
    if ended.any():
        problems.append(f"{spec}: in a calm hover ({CHECK_SCENARIO}, benchmark "
                        f"{scenario.loop.benchmark}) {int(ended.sum())} of {len(ended)} flights "
                        f"ended early ({', '.join(sorted(set(reasons)))})")
    elif errors.max() > HOVER_TOLERANCE:
        problems.append(f"{spec}: in a calm hover ({CHECK_SCENARIO}, benchmark "
                        f"{scenario.loop.benchmark}) a vehicle strayed {errors.max():.3f} m from "
                        f"its reference (a working controller stays within "
                        f"{HOVER_TOLERANCE} m)")
    return problems


def _fly(controller: Controller, scenario: Any, seeds: tuple[int, ...], steps: int
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]] | str:
    """Positions (steps, N, 3), each vehicle's largest error, which ended early and why, for
    ``steps`` steps with ``controller`` as a residual env's base, residual zero."""
    try:
        env = make_vector_env(len(seeds), scenario, base_controller=controller)
        env.reset(seed=list(seeds))
        core = env.core
        positions, largest = [], np.zeros(len(seeds))
        ended, reasons = np.zeros(len(seeds), dtype=bool), []
        for _ in range(min(steps, scenario.steps)):
            error = np.linalg.norm(core.state.position - core.reference.position, axis=1)
            largest = np.maximum(largest, np.where(ended, 0.0, error))
            positions.append(core.state.position.copy())
            _, _, terminated, truncated, _ = env.step(np.zeros((len(seeds), 4)))
            stopped = (terminated | truncated) & ~ended
            reasons += [core.termination_reason(int(i)) or "time limit"
                        for i in np.flatnonzero(stopped)]
            ended |= terminated
    except Exception as error:
        return (f"{controller.name}: flying {scenario.name} raised "
                f"{type(error).__name__}: {error}")
    return np.array(positions), largest, ended, reasons
