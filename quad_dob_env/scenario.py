"""The ``Scenario`` record: what a flight is, validated when it is built.

A trajectory (or a ``TrajectoryFamily``), disturbances, an initial state, a duration and a
clock, the actuation, the vehicle and the loop it flies in (``loop``, a ``LoopOptions``
resolved for them); its reference is checked flyable by differential flatness
(``feasibility``) or refused. The named scenarios are built in ``scenarios``.

The loop's options were ``Scenario`` fields until they became one record: they are still
taken flat wherever a scenario is made or changed (``Scenario(..., inner_rate=200.0)``,
``make_scenario``, ``with_changes``), and read from ``scenario.loop``; reading them off
the scenario (``scenario.inner_rate``) still works, with a DeprecationWarning naming
``scenario.loop.inner_rate``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import operator
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.benchmark import LOOP_FIELDS
from quad_dob_env.disturbances import Disturbance, GroundEffect
from quad_dob_env.feasibility import Feasibility, check_reference, refusal
from quad_dob_env.loop_options import (
    DEFAULT_LOOP_OPTIONS,
    LOOP_KEYS,
    LoopOptions,
    split_loop_keys,
)
from quad_dob_env.memory import check_memory
from quad_dob_env.params import ACTUATIONS, VehicleParams, get_vehicle
from quad_dob_env.so3 import project_to_so3
from quad_dob_env.trajectories import Trajectory, TrajectoryFamily
from quad_dob_env.validation import as_finite, as_vector3, unknown_name_error
from quad_dob_env.variation import Randomization, SensorNoise

# Bounds that keep a typo from asking for an absurd experiment: a control period from
# 0.1 ms to 0.1 s, at most a million steps per episode (its reference is tabulated), and
# at most 100 physics substeps per control step.
MIN_DT, MAX_DT, MAX_STEPS, MAX_SUBSTEPS = 1e-4, 0.1, 1_000_000, 100
# Bytes per row of the tables a scenario's flight builds (measured with tracemalloc, and
# rounded up): the core's reference table (8 fields x 3 float64) for each member, held
# twice while a grown table is concatenated; the feasibility check's arrays (448 B a row,
# one member at a time); the time-only disturbances, 3 channels x 3 float64 per sample.
REFERENCE_ROW_BYTES = 2 * 8 * 3 * 8
FEASIBILITY_ROW_BYTES = 512
DISTURBANCE_SAMPLE_BYTES = 3 * 3 * 8

@dataclass(frozen=True)
class Scenario:
    """Everything but the policy: what the vehicle must track, what disturbs it, for how long.

    Every scenario is checked on construction: its reference's thrust, moments, rotor thrusts
    and body rate by differential flatness (``quad_dob_env.feasibility``) must fit the
    vehicle's limits, or it is refused with the axis and the numbers (``allow_infeasible``
    builds it anyway); ``feasibility`` holds the margins.

    Initial state: ``initial_position`` plus a uniform offset in ``±initial_position_noise``
    per axis; ``initial_rotation`` times ``exp`` of a uniform rotation vector in
    ``±initial_attitude_noise`` per axis; the given velocity and body rates.
    ``floor_height`` None means open space (no floor, no crash on the ground). A start at
    ``initial_position`` that its position noise could draw at or below the floor is refused
    on construction, with the largest noise allowed: such a draw ended its episode at the
    first step. (A scenario that starts on its reference starts where the reference is.)
    """

    name: str
    vehicle: VehicleParams
    trajectory: Trajectory
    duration: float
    disturbance: Disturbance | None = None
    ground_effect: GroundEffect | None = None
    floor_height: float | None = None
    initial_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    initial_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    initial_rotation: tuple[tuple[float, ...], ...] = ((1.0, 0, 0), (0, 1.0, 0), (0, 0, 1.0))
    initial_angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    initial_position_noise: float = 0.0
    initial_attitude_noise: float = 0.0
    # [s] each episode starts at a point of the reference drawn uniformly from [0, this],
    # on it (position, velocity, flat attitude); time and the disturbances still start at 0
    reference_start_spread: float = 0.0
    dt: float = 0.01
    substeps: int = 1
    actuation: str = "rotors"
    # the vehicle loop (sensing, inner loop, motors, rotors, latencies, the benchmark), one
    # record (``quad_dob_env.loop_options``), resolved for this vehicle and clock when built;
    # its options may also be given flat (``Scenario(..., inner_rate=200.0)``)
    loop: LoopOptions = DEFAULT_LOOP_OPTIONS
    # [s] the "settled" scores (RMS errors) skip the start before this: the initial
    # transient (Neural-Fly's wind-tunnel figures skip their first 5 s, a warm-up lap)
    settle_time: float = 2.0
    randomization: Randomization | None = None
    description: str = field(default="", compare=False)
    # A reference that needs more than the actuators give is refused unless this is set.
    allow_infeasible: bool = field(default=False, compare=False)
    feasibility: Feasibility = field(init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.vehicle, VehicleParams):
            object.__setattr__(self, "vehicle", get_vehicle(self.vehicle))
        if not isinstance(self.trajectory, (Trajectory, TrajectoryFamily)):
            raise ValueError("Scenario.trajectory must be a Trajectory or a TrajectoryFamily, "
                             f"got {self.trajectory!r}")
        if self.disturbance is not None and not isinstance(self.disturbance, Disturbance):
            raise ValueError(
                f"Scenario.disturbance must be a Disturbance or None, got {self.disturbance!r}"
            )
        if self.ground_effect is not None:
            if not isinstance(self.ground_effect, GroundEffect):
                raise ValueError(f"Scenario.ground_effect must be a GroundEffect or None, "
                                 f"got {self.ground_effect!r}")
            if self.floor_height is None:
                raise ValueError("Scenario.ground_effect needs a floor: set floor_height")
            self.ground_effect.law(self.vehicle, self.floor_height)  # validates its heights
        if self.floor_height is not None:
            as_finite(self.floor_height, "Scenario.floor_height")
        randomization = self.randomization
        if randomization is not None and not isinstance(randomization, Randomization):
            if not isinstance(randomization, dict):
                raise ValueError(f"Scenario.randomization must be a Randomization, a dict of "
                                 f"its fields or None, got {randomization!r}")
            names = [f.name for f in dataclasses.fields(Randomization)]
            for key in randomization:
                if key not in names:
                    raise unknown_name_error("Randomization field", key, names)
            object.__setattr__(self, "randomization", Randomization(**randomization))
        # the clock and the actuation first: the loop is resolved on them
        dt = as_finite(self.dt, "Scenario.dt", MIN_DT)
        if dt > MAX_DT:
            raise ValueError(f"Scenario.dt must be in [{MIN_DT}, {MAX_DT}] s, got {self.dt!r}")
        duration = as_finite(self.duration, "Scenario.duration", dt)
        if duration / dt > MAX_STEPS:
            raise ValueError(f"Scenario.duration / dt must be at most {MAX_STEPS:,} steps (the "
                             f"reference is tabulated per step), got {duration / dt:,.0f}")
        if (not isinstance(self.substeps, (int, np.integer)) or isinstance(self.substeps, bool)
                or not 1 <= self.substeps <= MAX_SUBSTEPS):
            raise ValueError(f"Scenario.substeps must be an integer in [1, {MAX_SUBSTEPS}], "
                             f"got {self.substeps!r}")
        if self.actuation not in ACTUATIONS:
            raise unknown_name_error("actuation", self.actuation, ACTUATIONS)
        if not isinstance(self.loop, LoopOptions):
            raise ValueError(f"Scenario.loop must be a LoopOptions (quad_dob_env.loop_options),"
                             f" got {self.loop!r}; or give its options as flat keys "
                             f"({', '.join(LOOP_KEYS)})")
        loop = self.loop.resolved(self.vehicle, dt, self.actuation, self.name)
        object.__setattr__(self, "loop", loop)
        intervals = loop.inner_ticks(dt) * self.substeps
        if intervals > MAX_SUBSTEPS:
            raise ValueError(f"LoopOptions.inner_rate {loop.inner_rate:g} Hz with substeps "
                             f"{self.substeps} needs {intervals} physics intervals a step; at "
                             f"most {MAX_SUBSTEPS}")
        noise = as_finite(self.initial_position_noise, "Scenario.initial_position_noise", 0.0)
        as_finite(self.reference_start_spread, "Scenario.reference_start_spread", 0.0)
        if as_finite(self.initial_attitude_noise, "Scenario.initial_attitude_noise", 0.0) > np.pi:
            raise ValueError("Scenario.initial_attitude_noise is a rotation angle per axis in "
                             f"[0, pi], got {self.initial_attitude_noise!r}")
        for name in ("initial_position", "initial_velocity", "initial_angular_velocity"):
            object.__setattr__(self, name,
                               tuple(as_vector3(getattr(self, name), f"Scenario.{name}")))
        # a start drawn below the floor would end the episode at its first step, reported as
        # a crash at reset: refused here, whatever the draw. One that starts on its
        # reference starts where the reference is, which initial_position does not say
        if (self.floor_height is not None and not self.starts_on_reference
                and self.initial_position[2] - noise <= self.floor_height):
            clearance = self.initial_position[2] - self.floor_height
            if clearance <= 0.0:
                raise ValueError(
                    f"scenario {self.name!r}: initial_position starts the vehicle at or below "
                    f"its floor (height {self.initial_position[2]:g} m, floor at "
                    f"{self.floor_height:g} m); allowed: a start above the floor")
            raise ValueError(
                f"scenario {self.name!r}: initial_position_noise {noise:g} m can start the "
                f"vehicle at or below its floor (start height {self.initial_position[2]:g} m, "
                f"floor at {self.floor_height:g} m); allowed: a noise below {clearance:g} m, "
                "or a start higher above the floor")
        rotation = np.asarray(self.initial_rotation, dtype=float)
        if (rotation.shape != (3, 3) or not np.all(np.isfinite(rotation))
                or not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-9)
                or np.linalg.det(rotation) < 0):
            raise ValueError(
                "Scenario.initial_rotation must be a rotation matrix, got "
                f"{self.initial_rotation!r}"
            )
        object.__setattr__(self, "initial_rotation",
                           tuple(tuple(row) for row in project_to_so3(rotation).tolist()))
        object.__setattr__(self, "duration", duration)
        # (a flight shorter than it is scored on its last sample)
        object.__setattr__(self, "settle_time",
                           as_finite(self.settle_time, "Scenario.settle_time", 0.0))
        family = isinstance(self.trajectory, TrajectoryFamily)
        members = self.trajectory.members if family else (self.trajectory,)
        self._check_table_memory(len(members))
        # a family is as feasible as its hardest member
        checks = [check_reference(member, self.vehicle, self.actuation,
                                  duration + self.reference_start_spread, dt)
                  for member in members]
        hardest = min(range(len(checks)), key=lambda k: checks[k].worst.margin)
        feasibility = checks[hardest]
        if not feasibility.feasible and not self.allow_infeasible:
            name = (f"{self.name} (member {hardest}, a {self.trajectory.kinds[hardest]})"
                    if family else self.name)
            raise ValueError(refusal(name, self.vehicle, self.actuation, feasibility))
        object.__setattr__(self, "feasibility", feasibility)

    @property
    def rotor_time_constants(self) -> tuple[float, float]:
        """[s] the actuators' time constants as flown (``LoopOptions.rotor_time_constants``)."""
        return self.loop.rotor_time_constants(self.vehicle)

    @property
    def inner_ticks(self) -> int:
        """Inner-loop ticks per control step (1 without an inner loop)."""
        return self.loop.inner_ticks(self.dt)

    @property
    def integration_intervals(self) -> int:
        """CF4 steps per control step: ``substeps`` per inner tick."""
        return self.inner_ticks * self.substeps

    def _check_table_memory(self, members: int) -> None:
        """Refuse, before anything is tabulated, tables that would pass the memory budget
        (``quad_dob_env.memory``): the rows run from 0 to the duration plus the start
        spread, at dt."""
        rows = self.table_rows
        size = rows * (members * REFERENCE_ROW_BYTES + FEASIBILITY_ROW_BYTES
                       + (2 * self.integration_intervals + 1) * DISTURBANCE_SAMPLE_BYTES)
        check_memory(size, f"scenario {self.name!r}: {members} reference(s) tabulated over "
                     f"{rows:,} rows (duration {self.duration:g} s + reference_start_spread "
                     f"{self.reference_start_spread:g} s, at dt {self.dt:g} s)",
                     "use a larger dt, a shorter duration or reference_start_spread")

    @property
    def steps(self) -> int:
        """Control steps in one episode."""
        return math.floor(self.duration / self.dt + 1e-9)

    @property
    def starts_on_reference(self) -> bool:
        """Whether an episode starts on its reference (a family of several members, or a
        start spread) rather than at ``initial_position``."""
        family = isinstance(self.trajectory, TrajectoryFamily)
        return (family and len(self.trajectory.members) > 1) or self.start_spread_steps > 0

    @property
    def start_spread_steps(self) -> int:
        """The latest row of its reference an episode may start on."""
        return math.floor(self.reference_start_spread / self.dt + 1e-9)

    @property
    def table_rows(self) -> int:
        """Rows a vehicle's reference is tabulated over: a whole episode from its latest
        start."""
        return self.steps + 1 + self.start_spread_steps

    def initial_rotation_matrix(self) -> NDArray[np.float64]:
        return np.array(self.initial_rotation)

    def with_changes(self, **changes: object) -> Scenario:
        """A copy with fields replaced, validated like the original. The loop's options may
        come flat (``inner_rate=...``: laid over the loop as it was given, so a change of
        benchmark resolves the rest again) or as a ``loop`` record, which replaces it."""
        for key in changes:
            if key not in SCENARIO_KEYS:
                raise unknown_name_error("Scenario field or loop option", key, SCENARIO_KEYS)
        changes = dict(changes)
        loop = split_loop_keys(changes, changes.pop("loop", self.loop))
        if _same(loop.as_given(), self.loop.as_given()) and all(
                _same(value, getattr(self, key)) for key, value in changes.items()):
            # nothing changes (an env handed a built scenario and its own benchmark): the
            # scenario itself, not a copy validated again (that checks every reference)
            return self
        return dataclasses.replace(self, loop=loop, **changes)


def _taking_flat_loop_keys(generated: Callable[..., None]) -> Callable[..., None]:
    """The dataclass's own ``__init__``, taking the loop's options flat as well
    (``Scenario(..., inner_rate=200.0)``), as ``split_loop_keys`` lays them over ``loop``."""

    @functools.wraps(generated)
    def taking_flat_keys(self: Scenario, *args: Any, **fields: Any) -> None:
        if any(key in fields for key in LOOP_KEYS):
            fields["loop"] = split_loop_keys(fields, fields.get("loop"))
        generated(self, *args, **fields)

    return taking_flat_keys


Scenario.__init__ = _taking_flat_loop_keys(Scenario.__init__)  # type: ignore[method-assign]
# what ``make_scenario`` and ``with_changes`` take: the fields given when a scenario is made,
# and the loop's options flat
SCENARIO_KEYS = (*(f.name for f in dataclasses.fields(Scenario) if f.init), *LOOP_KEYS)


def _moved_into_the_loop(name: str, read: Callable[[LoopOptions], object],
                         replacement: str) -> property:
    """``Scenario.<name>``, read from the loop with a DeprecationWarning naming
    ``replacement``: code written before the loop became one record keeps working."""

    def deprecated(self: Scenario) -> object:
        warnings.warn(f"Scenario.{name} is deprecated: the vehicle loop is one record, read "
                      f"{replacement}", DeprecationWarning, stacklevel=2)
        return read(self.loop)

    return property(deprecated, doc=f"Deprecated: read ``{replacement}``.")


# the loop's options that were Scenario fields before the record (issue 52); options added
# since were never read from a Scenario and get no shim
FORMER_FIELDS = (*LOOP_FIELDS, "benchmark", "motor_lag", "motor_time_constant_scale",
                 "extra_latency", "unmodelled_pose_latency")
for _name in FORMER_FIELDS:
    setattr(Scenario, _name, _moved_into_the_loop(
        _name, operator.attrgetter(_name), f"scenario.loop.{_name}"))
Scenario.sensors = _moved_into_the_loop(  # type: ignore[attr-defined]
    "sensors", lambda loop: loop.sensing if isinstance(loop.sensing, SensorNoise) else None,
    "scenario.loop.sensing")
Scenario.loop_given = _moved_into_the_loop(  # type: ignore[attr-defined]
    "loop_given", lambda loop: {key: getattr(loop.as_given(), key) for key in LOOP_FIELDS},
    "scenario.loop.as_given()")


def _same(new: object, old: object) -> bool:
    """Whether a changed field's value is the one it has: equal and of one type; arrays and
    anything whose equality is not a plain bool count as changed (the safe side: a copy)."""
    if new is old:
        return True
    try:
        return type(new) is type(old) and bool(new == old)
    except (TypeError, ValueError):
        return False
