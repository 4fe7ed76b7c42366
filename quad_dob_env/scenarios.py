"""Scenarios are data: a trajectory, disturbances, an initial state, a duration and a clock.

``make_scenario("paper-II")`` builds a named one; options either go to its builder (such as
``torque_reading`` or ``vehicle``) or replace a ``Scenario`` field (``dt``, ``duration``,
``substeps``, ...). ``gym.make``, the CLI, evaluation and the paper reproduction all go
through here, so "paper-II" means one thing everywhere.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.disturbances import (
    AtanRamp,
    Constant,
    Disturbance,
    Dryden,
    GroundEffect,
    Gust,
)
from quad_dob_env.params import ACTUATIONS, VehicleParams, get_vehicle
from quad_dob_env.so3 import project_to_so3
from quad_dob_env.trajectories import Hover, PaperHelix, TakeoffHoverLanding, Trajectory
from quad_dob_env.validation import as_finite, as_vector3, unknown_name_error

# The paper's translational disturbance magnitudes [N], Scenarios I, II, II-A.
PAPER_FORCE = (1.3, 2.0, 2.6)
# The paper writes "d_x = 0.6 d_Ω". Read literally, d_Ω = d_x / 0.6 reaches 4.3 N m, which
# kR = 8.81 cannot hold; the default reads it as d_Ω = 0.6 d_x.
TORQUE_READINGS: dict[str, float] = {"0.6*dx": 0.6, "dx/0.6": 1 / 0.6}


# Bounds that keep a typo from asking for an absurd experiment: a control period from
# 0.1 ms to 0.1 s, at most a million steps per episode (its reference is tabulated), and
# at most 100 physics substeps per control step.
MIN_DT, MAX_DT, MAX_STEPS, MAX_SUBSTEPS = 1e-4, 0.1, 1_000_000, 100

@dataclass(frozen=True)
class SensorNoise:
    """What the agent observes, optional: Gaussian noise with these standard deviations on
    the position (m), velocity (m/s), attitude (rad, a random rotation of that size per
    axis) and body rates (rad/s) in the observation, which arrives ``delay_steps`` control
    steps late. Reward, termination and ``info`` use the true state."""

    position_std: float = 0.0
    velocity_std: float = 0.0
    attitude_std: float = 0.0
    rate_std: float = 0.0
    delay_steps: int = 0

    def __post_init__(self) -> None:
        for name in ("position_std", "velocity_std", "attitude_std", "rate_std"):
            as_finite(getattr(self, name), f"SensorNoise.{name}", 0.0)
        if not isinstance(self.delay_steps, (int, np.integer)) or self.delay_steps < 0:
            raise ValueError(f"SensorNoise.delay_steps must be an integer >= 0, got "
                             f"{self.delay_steps!r}")

    @property
    def is_noisy(self) -> bool:
        return any((self.position_std, self.velocity_std, self.attitude_std, self.rate_std))


@dataclass(frozen=True)
class Randomization:
    """Domain randomisation, optional: at each reset every vehicle's mass, inertia and drag
    coefficients are the vehicle's times a factor drawn uniformly from these (low, high)
    ranges (wind intensity and direction: ``Dryden(intensity_scale=..., direction=None)``).
    The draws are in the reset ``info["sampled"]``."""

    mass: tuple[float, float] = (1.0, 1.0)
    inertia: tuple[float, float] = (1.0, 1.0)
    drag: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        for name in ("mass", "inertia", "drag"):
            value = getattr(self, name)
            if np.shape(value) != (2,):
                raise ValueError(f"Randomization.{name} must be a (low, high) pair, got {value!r}")
            low, high = (as_finite(v, f"Randomization.{name}", 0.0, strictly=True)
                         for v in value)
            if high < low:
                raise ValueError(f"Randomization.{name} needs low <= high, got {value!r}")
            object.__setattr__(self, name, (low, high))


@dataclass(frozen=True)
class Scenario:
    """Everything but the policy: what the vehicle must track, what disturbs it, for how long.

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
    dt: float = 0.01
    substeps: int = 1
    actuation: str = "rotors"
    drag: bool = False  # the vehicle's drag acts on the air-relative velocity (needed for wind)
    motor_lag: bool = False  # actuators follow commands with the vehicle's motor time constant
    sensors: SensorNoise | None = None
    randomization: Randomization | None = None
    description: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.vehicle, VehicleParams):
            object.__setattr__(self, "vehicle", get_vehicle(self.vehicle))
        if not isinstance(self.trajectory, Trajectory):
            raise ValueError(f"Scenario.trajectory must be a Trajectory, got {self.trajectory!r}")
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
        for name, kind in (("sensors", SensorNoise), ("randomization", Randomization)):
            value = getattr(self, name)
            if value is not None and not isinstance(value, kind):
                if not isinstance(value, dict):
                    raise ValueError(f"Scenario.{name} must be a {kind.__name__}, a dict of its "
                                     f"fields or None, got {value!r}")
                fields_ = [f.name for f in dataclasses.fields(kind)]
                for key in value:
                    if key not in fields_:
                        raise unknown_name_error(f"{kind.__name__} field", key, fields_)
                object.__setattr__(self, name, kind(**value))
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

    @property
    def steps(self) -> int:
        """Control steps in one episode."""
        return math.floor(self.duration / self.dt + 1e-9)

    def initial_rotation_matrix(self) -> NDArray[np.float64]:
        return np.array(self.initial_rotation)

    def with_changes(self, **changes: object) -> Scenario:
        """A copy with fields replaced, validated like the original."""
        fields = [f.name for f in dataclasses.fields(self)]
        for key in changes:
            if key not in fields:
                raise unknown_name_error("Scenario field", key, fields)
        return dataclasses.replace(self, **changes)


def _paper(kind: str, *, vehicle: str | VehicleParams = "paper",
           torque_reading: str = "0.6*dx") -> Scenario:
    if torque_reading not in TORQUE_READINGS:
        raise unknown_name_error("torque_reading", torque_reading, TORQUE_READINGS)
    force = np.array(PAPER_FORCE)
    torque = TORQUE_READINGS[torque_reading] * force
    disturbance = {
        "none": None,
        "I": AtanRamp(force, torque, time_scale=2.0),
        "II": Constant(force, torque),
        "IIA": Constant(force, torque).during(5.0, 7.0),
    }[kind]
    what = {"none": "no disturbance", "I": "d_x = [1.3, 2.0, 2.6] atan(t/2)",
            "II": "constant d_x = [1.3, 2.0, 2.6] N", "IIA": "II's constants for 5 <= t < 7 s"}
    return Scenario(
        name=f"paper-{kind}", vehicle=get_vehicle(vehicle), trajectory=PaperHelix(),
        duration=10.0, disturbance=disturbance, dt=0.01, actuation="wrench",
        description=f"Paper helix, {what[kind]}, d_Ω = {torque_reading} "
                    "(moments applied directly, as in the paper's model)",
    )


def _ground_effect_landing(*, vehicle: str | VehicleParams = "paper",
                           model: str = "paper") -> Scenario:
    return Scenario(
        name="ground-effect-landing", vehicle=get_vehicle(vehicle),
        trajectory=TakeoffHoverLanding(start_height=0.15, hover_height=0.15, end_height=0.05,
                                       climb_time=0.0, hover_time=2.0, descent_time=3.0),
        duration=8.0, ground_effect=GroundEffect(model), floor_height=0.0,
        initial_position=(0.0, 0.0, 0.15),
        description=f"Hover at 0.15 m, descend to 0.05 m in ground effect ({model} law)",
    )


def _hover(*, vehicle: str | VehicleParams = "paper", height: float = 1.0,
           step_force: float = 0.0) -> Scenario:
    params = get_vehicle(vehicle)
    disturbance = None
    if step_force:
        # a fraction of the vehicle's weight, so the scenario means the same for any vehicle
        disturbance = Constant(force=(step_force * params.hover_thrust, 0.0, 0.0)).during(3.0, 6.0)
    return Scenario(
        name="hover-step-force" if step_force else "hover-calm", vehicle=params,
        trajectory=Hover((0.0, 0.0, height)), duration=10.0, disturbance=disturbance,
        floor_height=0.0, initial_position=(0.0, 0.0, height), initial_position_noise=0.1,
        initial_attitude_noise=0.1,
        description="Hold a hover point from a perturbed start"
        + (f"; +x force of {step_force:g} weights for 3 <= t < 6 s" if step_force else ""),
    )


def _dryden_helix(*, vehicle: str | VehicleParams = "paper", intensity: str = "moderate",
                  gusts: bool = False, wind_scale: float = 1.0) -> Scenario:
    # wind_scale multiplies the mean wind and the turbulence (for sweeps over intensity)
    scale = as_finite(wind_scale, "wind_scale", 0.0)
    disturbance: Disturbance = Dryden(intensity, altitude=2.0, direction=None,
                                      intensity_scale=None if scale == 1.0 else (scale, scale))
    if gusts:
        disturbance = disturbance + _gust_pair()
    return Scenario(
        name="dryden-helix-gusts" if gusts else "dryden-helix", vehicle=get_vehicle(vehicle),
        trajectory=PaperHelix(), duration=10.0, disturbance=disturbance, drag=True,
        motor_lag=True,
        description=f"Paper helix in {intensity} Dryden turbulence with its mean wind, from a "
                    "random direction" + (", plus two 1-cosine gusts" if gusts else "")
                    + "; drag, motor lag, physical rotors",
    )


def _gust_pair() -> Disturbance:
    return (Gust(4.0, direction=(1.0, 0.0, 0.0), start=2.0, length=10.0, speed=10.0, hold=1.0)
            + Gust(4.0, direction=(0.0, 1.0, 0.3), start=6.0, length=5.0, speed=10.0))


def _gusty_hover(*, vehicle: str | VehicleParams = "paper") -> Scenario:
    return Scenario(
        name="gusty-hover", vehicle=get_vehicle(vehicle), trajectory=Hover((0.0, 0.0, 1.0)),
        duration=10.0, disturbance=Dryden("light", altitude=1.0, direction=None) + _gust_pair(),
        floor_height=0.0, initial_position=(0.0, 0.0, 1.0), drag=True, motor_lag=True,
        description="Hover at 1 m in light Dryden turbulence and two 4 m/s 1-cosine gusts; "
                    "drag, motor lag, physical rotors",
    )


def _takeoff_landing_wind(*, vehicle: str | VehicleParams = "paper") -> Scenario:
    return Scenario(
        name="takeoff-landing-wind", vehicle=get_vehicle(vehicle),
        trajectory=TakeoffHoverLanding(start_height=0.05, hover_height=1.0, end_height=0.05,
                                       climb_time=3.0, hover_time=3.0, descent_time=3.0),
        duration=10.0, disturbance=Dryden("light", altitude=1.0, direction=None) + Gust(
            3.0, direction=(1.0, 1.0, 0.0), start=4.0, length=10.0, speed=10.0),
        ground_effect=GroundEffect("paper"), floor_height=0.0,
        initial_position=(0.0, 0.0, 0.05), drag=True, motor_lag=True,
        description="Take off from 5 cm, hover at 1 m, land to 5 cm through ground effect in "
                    "light turbulence and a 3 m/s gust; drag, motor lag, physical rotors",
    )


SCENARIOS: dict[str, Callable[..., Scenario]] = {
    "paper-none": lambda **kw: _paper("none", **kw),
    "paper-I": lambda **kw: _paper("I", **kw),
    "paper-II": lambda **kw: _paper("II", **kw),
    "paper-IIA": lambda **kw: _paper("IIA", **kw),
    "ground-effect-landing": _ground_effect_landing,
    "hover-calm": _hover,
    "hover-step-force": lambda **kw: _hover(step_force=0.2, **kw),
    "dryden-helix": _dryden_helix,
    "dryden-helix-gusts": lambda **kw: _dryden_helix(gusts=True, **kw),
    "gusty-hover": _gusty_hover,
    "takeoff-landing-wind": _takeoff_landing_wind,
}
_BUILDER_OPTIONS: dict[str, tuple[str, ...]] = {
    "paper-none": ("vehicle", "torque_reading"), "paper-I": ("vehicle", "torque_reading"),
    "paper-II": ("vehicle", "torque_reading"), "paper-IIA": ("vehicle", "torque_reading"),
    "ground-effect-landing": tuple(inspect.signature(_ground_effect_landing).parameters),
    "hover-calm": tuple(inspect.signature(_hover).parameters),
    "hover-step-force": ("vehicle", "height"),
    "dryden-helix": ("vehicle", "intensity", "wind_scale"),
    "dryden-helix-gusts": ("vehicle", "intensity", "wind_scale"),
    "gusty-hover": ("vehicle",),
    "takeoff-landing-wind": ("vehicle",),
}


def list_scenarios() -> list[str]:
    return list(SCENARIOS)


def make_scenario(scenario: str | Scenario, **options: object) -> Scenario:
    """The named scenario with ``options`` applied (builder options, then Scenario fields)."""
    if isinstance(scenario, Scenario):
        return scenario.with_changes(**options) if options else scenario
    if scenario not in SCENARIOS:
        raise unknown_name_error("scenario", scenario, SCENARIOS)
    builder_options = {k: options.pop(k) for k in list(options)
                       if k in _BUILDER_OPTIONS[scenario]}
    fields = [f.name for f in dataclasses.fields(Scenario)]
    for key in options:
        if key not in fields:
            raise unknown_name_error(f"option for scenario {scenario!r}", key,
                                     [*_BUILDER_OPTIONS[scenario], *fields])
    built = SCENARIOS[scenario](**builder_options)
    return built.with_changes(**options) if options else built
