"""The ``Scenario`` record: what a flight is, validated when it is built.

A trajectory (or a ``TrajectoryFamily``), disturbances, an initial state, a duration and a
clock, the actuation and the vehicle; its reference is checked flyable by differential
flatness (``feasibility``) or refused. The named scenarios are built in ``scenarios``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.benchmark import BENCHMARKS, LOOP_FIELDS, loop_fields
from quad_dob_env.disturbances import Disturbance, GroundEffect
from quad_dob_env.dynamics.throttle import ThrottleMap
from quad_dob_env.feasibility import Feasibility, check_reference, refusal
from quad_dob_env.memory import check_memory
from quad_dob_env.params import ACTUATIONS, VehicleParams, get_vehicle
from quad_dob_env.sensing.models import SensorSuite, resolve_sensing
from quad_dob_env.so3 import project_to_so3
from quad_dob_env.trajectories import Trajectory, TrajectoryFamily
from quad_dob_env.validation import as_finite, as_vector3, unknown_name_error
from quad_dob_env.variation import ModelTolerance, Randomization, SensorNoise

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
    ``floor_height`` None means open space (no floor, no crash on the ground).
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
    # the vehicle's drag acts on the air-relative velocity (needed for wind); None: as
    # ``benchmark`` says (v1: no, v2: yes)
    drag: bool | None = None
    motor_lag: bool = False  # actuators follow commands with the vehicle's motor time constant
    # What every policy reads (``quad_dob_env.sensing``): a preset name (``ideal``, ``mocap``,
    # ``gnss-imu``), a SensorSuite, a SensorNoise, a dict of either's fields, or None
    # (ideal: the true state). ``sensors`` is its SensorNoise case, kept by that name.
    sensing: SensorSuite | SensorNoise | str | None = None
    sensors: SensorNoise | None = None
    # [s] added to every reading (pose, IMU, rotors alike), resolved on the control grid
    # (the first step at or after it)
    extra_latency: float = 0.0
    # [s] the pose fix (a SensorSuite's) arrives this much later than the suite says, and
    # its estimator, told the suite's latency, does not know it: latency on the outer
    # loop's path alone (mocap pipeline, the link to the vehicle), not on the autopilot's
    # own IMU and rotor telemetry (Benchmark v3's tuning margin, docs/benchmark-v3.md)
    unmodelled_pose_latency: float = 0.0
    # Benchmark v3: the pose fix's latency (its own plus extra_latency) resolved on the inner
    # loop's tick grid, not the control grid: at 50 Hz a 10 ms pipeline stays 10 ms (a
    # SensorSuite's pose; the IMU and rotor telemetry stay on the control grid)
    pose_latency_on_ticks: bool | None = None
    # the rotors' time constant is the vehicle's times this (needs motor_lag or speed_motors)
    motor_time_constant_scale: float = 1.0
    # [s] the rotor speed's time constants (spin-up, spin-down) on speed motors, in place of
    # the vehicle's one ``motor_time_constant`` for both; ``motor_time_constant_scale``
    # scales both. Here and in the v3 fields below, None is as ``benchmark`` says (v3 sets
    # its sourced values, v1 and v2 none) and False is off
    motor_time_constants: tuple[float, float] | None = None
    # Benchmark v2's vehicle loop, one switch per factor (``quad_dob_env.dynamics.rotors``),
    # each off giving v1's flight bit for bit; None: as ``benchmark`` says (v1: off, v2: on;
    # quad_dob_env.benchmark):
    # [Hz] the attitude loop's rate, a multiple of the control rate 1/dt: the controllers'
    # attitude laws (and thrust_rates' rate loop) run at it on the inner-rate estimate, the
    # physics in one interval per tick; 0 (None under v1): one controller at 1/dt
    inner_rate: float | None = None
    # motors on rotor speed (first-order in ω, thrust and yaw torque ∝ ω², with the
    # vehicle's motor time constant), replacing motor_lag's lag of the thrust
    speed_motors: bool | None = None
    # per-episode thrust coefficient and battery sag within the flight, seeded
    thrust_uncertainty: bool | None = None
    # Benchmark v3's throttle between the autopilot and the rotors (``dynamics.throttle``):
    # the rotors' thrust per throttle, the autopilot's belief of it and the battery under
    # both, drawn per episode; it replaces thrust_uncertainty and needs speed motors
    throttle_map: ThrottleMap | None = None
    # [Hz] Benchmark v3: the autopilot's gyro low-pass (2nd-order Butterworth, at the inner
    # rate) on the rates every inner law reads; None: none. Needs an inner loop
    gyro_cutoff: float | None = None
    # Benchmark v3: the rotors' vibration on the IMU as the autopilot's filters leave it,
    # (gyroscope [rad/s], accelerometer [m/s²]) RMS per axis, white on every reading; needs a
    # SensorSuite's IMU (``sensing``)
    imu_vibration: tuple[float, float] | None = None
    # Benchmark v3: the controllers' model of the vehicle (mass, inertia, thrust
    # coefficient) off the truth within these tolerances, drawn per episode
    model_tolerance: ModelTolerance | None = None
    # rotor drag and its moment, thrust with axial inflow; they replace drag_linear
    rotor_aerodynamics: bool | None = None
    # "v1" or "v2": the loop every field above left None takes (quad_dob_env.benchmark)
    benchmark: str = "v1"
    # [s] the "settled" scores (RMS errors) skip the start before this: the initial
    # transient (Neural-Fly's wind-tunnel figures skip their first 5 s, a warm-up lap)
    settle_time: float = 2.0
    randomization: Randomization | None = None
    description: str = field(default="", compare=False)
    # A reference that needs more than the actuators give is refused unless this is set.
    allow_infeasible: bool = field(default=False, compare=False)
    feasibility: Feasibility = field(init=False, compare=False, repr=False)
    # the loop fields (``quad_dob_env.benchmark.LOOP_FIELDS``) as given, before the benchmark
    loop_given: dict = field(init=False, compare=False, repr=False, default=None)

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
        for name, kind in (("sensors", SensorNoise), ("randomization", Randomization),
                           ("throttle_map", ThrottleMap),
                           ("model_tolerance", ModelTolerance)):
            value = getattr(self, name)
            if value is not None and value is not False and not isinstance(value, kind):
                if not isinstance(value, dict):
                    raise ValueError(f"Scenario.{name} must be a {kind.__name__}, a dict of its "
                                     f"fields or None, got {value!r}")
                fields_ = [f.name for f in dataclasses.fields(kind)]
                for key in value:
                    if key not in fields_:
                        raise unknown_name_error(f"{kind.__name__} field", key, fields_)
                object.__setattr__(self, name, kind(**value))
        self._resolve_benchmark()
        sensing = resolve_sensing(self.sensing)
        if self.sensors is not None:
            if sensing is not None and sensing != self.sensors:
                raise ValueError(f"Scenario.sensors is the sensing=SensorNoise(...) case: give "
                                 f"one of them, got sensing={self.sensing!r} and sensors="
                                 f"{self.sensors!r}")
            sensing = self.sensors
        object.__setattr__(self, "sensing", sensing)
        object.__setattr__(self, "sensors", sensing if isinstance(sensing, SensorNoise) else None)
        self._check_vibration()
        object.__setattr__(self, "extra_latency",
                           as_finite(self.extra_latency, "Scenario.extra_latency", 0.0))
        object.__setattr__(self, "unmodelled_pose_latency", as_finite(
            self.unmodelled_pose_latency, "Scenario.unmodelled_pose_latency", 0.0))
        self._check_pose_ticks()
        scale = as_finite(self.motor_time_constant_scale, "Scenario.motor_time_constant_scale",
                          0.0, strictly=True)
        if scale != 1.0 and not (self.motor_lag or self.speed_motors):
            raise ValueError(f"Scenario.motor_time_constant_scale = {scale:g} scales the motor "
                             f"lag, but scenario {self.name!r} flies without it: set "
                             f"motor_lag=True (or speed_motors=True) too")
        object.__setattr__(self, "motor_time_constant_scale", scale)
        self._check_motor_time_constants()
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
        as_finite(self.initial_position_noise, "Scenario.initial_position_noise", 0.0)
        as_finite(self.reference_start_spread, "Scenario.reference_start_spread", 0.0)
        if as_finite(self.initial_attitude_noise, "Scenario.initial_attitude_noise", 0.0) > np.pi:
            raise ValueError("Scenario.initial_attitude_noise is a rotation angle per axis in "
                             f"[0, pi], got {self.initial_attitude_noise!r}")
        for name in ("initial_position", "initial_velocity", "initial_angular_velocity"):
            object.__setattr__(self, name,
                               tuple(as_vector3(getattr(self, name), f"Scenario.{name}")))
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
        self._check_rotor_factors()
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

    def _resolve_benchmark(self) -> None:
        """The loop fields left None, as ``benchmark`` sets them."""
        if self.benchmark not in BENCHMARKS:
            raise unknown_name_error("benchmark", self.benchmark, BENCHMARKS)
        given = {key: getattr(self, key) for key in LOOP_FIELDS}
        object.__setattr__(self, "loop_given", dict(given))
        if given["sensing"] is None:
            given["sensing"] = self.sensors  # SensorNoise is sensing too
        dt = as_finite(self.dt, "Scenario.dt", MIN_DT) if self.benchmark != "v1" else 0.01
        for key, value in loop_fields(self.benchmark, given, dt, self.actuation,
                                      self.name, self.vehicle).items():
            object.__setattr__(self, key, value)

    def _check_vibration(self) -> None:
        given = self.imu_vibration
        if given is None:
            return
        if not isinstance(given, (tuple, list)) or len(given) != 2:
            raise ValueError(f"Scenario.imu_vibration must be (gyroscope [rad/s], "
                             f"accelerometer [m/s²]) RMS, or None, got {given!r}")
        pair = tuple(as_finite(value, f"Scenario.imu_vibration[{k}]", 0.0)
                     for k, value in enumerate(given))
        if not isinstance(self.sensing, SensorSuite):
            raise ValueError(f"Scenario.imu_vibration shakes an IMU, but scenario "
                             f"{self.name!r} senses {self.sensing!r}: give sensing a suite "
                             "with an IMU ('mocap', 'gnss-imu')")
        object.__setattr__(self, "imu_vibration", pair)

    def _check_pose_ticks(self) -> None:
        if self.pose_latency_on_ticks and not isinstance(self.sensing, SensorSuite):
            raise ValueError(f"Scenario.pose_latency_on_ticks resolves a sensor suite's pose "
                             f"latency, but scenario {self.name!r} senses {self.sensing!r}: "
                             "give sensing a suite ('mocap', 'gnss-imu')")
        if self.unmodelled_pose_latency and not isinstance(self.sensing, SensorSuite):
            raise ValueError(f"Scenario.unmodelled_pose_latency "
                             f"({self.unmodelled_pose_latency:g} s) delays a sensor suite's "
                             f"pose fix, but scenario {self.name!r} senses {self.sensing!r}: "
                             "give sensing a suite ('mocap', 'gnss-imu'), or use "
                             "extra_latency")

    def _check_motor_time_constants(self) -> None:
        given = self.motor_time_constants
        if given is None:
            return
        if (not isinstance(given, (tuple, list)) or len(given) != 2
                or isinstance(given, str)):
            raise ValueError(f"Scenario.motor_time_constants must be (spin-up, spin-down) in "
                             f"seconds, or None (the vehicle's), got {given!r}")
        pair = tuple(as_finite(value, f"Scenario.motor_time_constants[{k}]", 0.0, strictly=True)
                     for k, value in enumerate(given))
        if not self.speed_motors:
            raise ValueError(f"Scenario.motor_time_constants {pair} are the rotor speed's, "
                             f"but scenario {self.name!r} flies without speed motors: set "
                             "speed_motors=True (or benchmark='v2')")
        object.__setattr__(self, "motor_time_constants", pair)

    @property
    def rotor_time_constants(self) -> tuple[float, float]:
        """[s] the actuators' time constants as flown, scale applied: (spin-up, spin-down),
        equal but for speed motors given ``motor_time_constants``; (0, 0) without a lag."""
        if not (self.motor_lag or self.speed_motors):
            return 0.0, 0.0
        up, down = ((self.vehicle.motor_time_constant,) * 2 if self.motor_time_constants is None
                    else self.motor_time_constants)
        return up * self.motor_time_constant_scale, down * self.motor_time_constant_scale

    def _check_rotor_factors(self) -> None:
        if not isinstance(self.pose_latency_on_ticks, (bool, np.bool_)):
            raise ValueError(f"Scenario.pose_latency_on_ticks must be True or False (None: as "
                             f"the benchmark says), got {self.pose_latency_on_ticks!r}")
        for name in ("speed_motors", "thrust_uncertainty", "rotor_aerodynamics"):
            value = getattr(self, name)
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"Scenario.{name} must be True or False, got {value!r}")
            if value and self.actuation != "rotors":
                raise ValueError(f"Scenario.{name} models the rotors, but scenario "
                                 f"{self.name!r} flies actuation={self.actuation!r} (the "
                                 "paper's wrench, no rotors): use actuation='rotors'")
        if self.throttle_map is not None:
            if not self.speed_motors or self.thrust_uncertainty:
                raise ValueError(f"Scenario.throttle_map maps throttle to the rotors' speed and "
                                 f"replaces thrust_uncertainty's draws, but scenario "
                                 f"{self.name!r} flies speed_motors={self.speed_motors}, "
                                 f"thrust_uncertainty={self.thrust_uncertainty}: set "
                                 "speed_motors=True, thrust_uncertainty=False")
        if (self.model_tolerance is not None and self.model_tolerance.thrust_coefficient
                and not self.speed_motors):
            raise ValueError(f"Scenario.model_tolerance's thrust coefficient is the speed "
                             f"motors' k_F, but scenario {self.name!r} flies without them: "
                             "set speed_motors=True, or leave its thrust_coefficient 0")
        if self.rotor_aerodynamics and not self.drag:
            raise ValueError(f"Scenario.rotor_aerodynamics acts on the air-relative velocity, "
                             f"but scenario {self.name!r} flies without drag: set drag=True")
        if self.inner_rate is not None:
            rate = as_finite(self.inner_rate, "Scenario.inner_rate", 0.0, strictly=True)
            ticks = rate * self.dt
            if abs(ticks - round(ticks)) > 1e-6 or round(ticks) < 1:
                raise ValueError(
                    f"Scenario.inner_rate must be a whole multiple of the control rate "
                    f"1/dt = {1 / self.dt:g} Hz (e.g. {2 / self.dt:g}, {4 / self.dt:g}), got "
                    f"{self.inner_rate!r}")
            if round(ticks) * self.substeps > MAX_SUBSTEPS:
                raise ValueError(f"Scenario.inner_rate {rate:g} Hz with substeps "
                                 f"{self.substeps} needs {round(ticks) * self.substeps} physics "
                                 f"intervals a step; at most {MAX_SUBSTEPS}")
            object.__setattr__(self, "inner_rate", float(rate))
        if self.gyro_cutoff is not None:
            if self.inner_rate is None:
                raise ValueError(f"Scenario.gyro_cutoff filters the rates the inner loop "
                                 f"reads, but scenario {self.name!r} has no inner loop: set "
                                 "inner_rate (or benchmark='v2')")
            cutoff = as_finite(self.gyro_cutoff, "Scenario.gyro_cutoff", 0.0, strictly=True)
            if cutoff >= self.inner_rate / 2:
                raise ValueError(f"Scenario.gyro_cutoff must be below the inner loop's Nyquist "
                                 f"frequency, {self.inner_rate / 2:g} Hz, got {cutoff:g}")
            object.__setattr__(self, "gyro_cutoff", cutoff)

    @property
    def inner_ticks(self) -> int:
        """Inner-loop ticks per control step (1 without an inner loop)."""
        return 1 if self.inner_rate is None else round(self.inner_rate * self.dt)

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
        """A copy with fields replaced, validated like the original."""
        fields = [f.name for f in dataclasses.fields(self)]
        for key in changes:
            if key not in fields:
                raise unknown_name_error("Scenario field", key, fields)
        # ``sensors`` is ``sensing``'s SensorNoise case: a change of one replaces both
        if "sensing" in changes and "sensors" not in changes:
            changes = {**changes, "sensors": None}
        elif "sensors" in changes and "sensing" not in changes:
            changes = {**changes, "sensing": None}
        # the loop fields as they were given (None: the benchmark's), so a change of
        # benchmark resolves them again
        given = {**{key: getattr(self, key) for key in changes}, **{
            key: value for key, value in self.loop_given.items() if key in changes}}
        if all(_same(changes[key], given[key]) for key in changes):
            # nothing changes (an env handed a built scenario and its own benchmark): the
            # scenario itself, not a copy validated again (that checks every reference)
            return self
        return dataclasses.replace(self, **{**self.loop_given, **changes})


def _same(new: object, old: object) -> bool:
    """Whether a changed field's value is the one it has: equal and of one type; arrays and
    anything whose equality is not a plain bool count as changed (the safe side: a copy)."""
    if new is old:
        return True
    try:
        return type(new) is type(old) and bool(new == old)
    except (TypeError, ValueError):
        return False
