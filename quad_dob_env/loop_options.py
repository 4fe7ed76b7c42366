"""``LoopOptions``: the vehicle loop a scenario flies, in one frozen record, validated once.

Everything between the policy's command and the force on the airframe, and between the true
state and what the policy reads, is one option of this record; ``Scenario.loop`` holds it
(the ``Scenario`` keeps what is flown: trajectory, disturbances, start, clock, vehicle).

| option                      | what it does                                          | v2 | v3 |
|-----------------------------|-------------------------------------------------------|----|----|
| ``benchmark``               | ``"v1"`` to ``"v4"``: what the None ones are           | -  | -  |
| ``sensing``                 | what every policy reads (``quad_dob_env.sensing``)     | x  | x  |
| ``inner_rate``              | [Hz] the attitude loop, a multiple of 1/dt; 0: none    | x  | x  |
| ``speed_motors``            | motors on rotor speed, thrust and yaw torque ∝ ω²      | x  | x  |
| ``thrust_uncertainty``      | per-episode thrust coefficient and battery sag         | x  |    |
| ``rotor_aerodynamics``      | rotor drag and its moment, thrust with axial inflow    | x  | x  |
| ``drag``                    | drag on the air-relative velocity (needed for wind)    | x  | x  |
| ``motor_time_constants``    | [s] the rotor speed's (spin-up, spin-down)             |    | x  |
| ``throttle_map``            | throttle to thrust, the autopilot's belief, battery    |    | x  |
| ``model_tolerance``         | the controllers' model off the truth                   |    | x  |
| ``gyro_cutoff``             | [Hz] the autopilot's gyro low-pass at the inner rate   |    | x  |
| ``imu_vibration``           | the rotors' vibration on the IMU, (gyro, accel) RMS    |    | x  |
| ``pose_latency_on_ticks``   | the pose fix's latency on the inner loop's tick grid   |    | x  |
| ``motor_lag``               | v1's lag of the thrust (speed motors replace it)       |    |    |
| ``motor_time_constant_scale`` | the rotors' time constants times this (the margin)   |    |    |
| ``extra_latency``           | [s] on every reading, on the control grid (the margin) |    |    |
| ``unmodelled_pose_latency`` | [s] on the pose fix, unknown to its estimator (margin) |    |    |
| ``imu_vibration_scale``     | ``imu_vibration`` times this                           |    |    |
| ``rotor_thrust_mismatch``   | each rotor's k_F off the nominal by up to ± this       |    |    |
| ``estimator_wrench``        | what the estimators are told was applied: ``"applied"`` |    |    |
|                             | (the rotors' output) or ``"commanded"`` (the autopilot's) |  |    |
| ``airframe_drag``           | the airframe's drag in place of the vehicle preset's   |    |    |
| ``imu_vibration_tones``     | the rotors' vibration on the IMU as tones              |    |    |

The fifteen benchmark options (``LOOP_FIELDS``) left None are what ``benchmark`` sets
(``quad_dob_env.benchmark.loop_fields``, the one resolution; the v2 and v3 columns say which
it turns on; v4, v3's loop with its own ``throttle_map``, sets the last three, with
``estimator_wrench="commanded"``, and no white ``imu_vibration``), so one option given
keeps its value under any benchmark and one factor is switched off in turn; v3's and v4's
own are switched off with ``False`` (``gyro_cutoff``: 0; ``estimator_wrench``: "applied").

Ranges: ``motor_time_constant_scale``, ``unmodelled_pose_latency`` and
``imu_vibration_scale`` take a number or a (low, high) range, drawn uniformly per episode for
each vehicle (the draws in ``info["sampled"]``).

Where the other options went, and why: ``motor_lag`` and the robustness margin's knobs
(``motor_time_constant_scale``, ``extra_latency``, ``unmodelled_pose_latency``) are parts of
the vehicle loop too (a lag, a slower motor, a late reading), so they live here, though no
benchmark sets them. ``sensors`` is no option of its own: it was ``sensing``'s
``SensorNoise`` spelling, and stays a flat key that ``split_loop_keys`` turns into
``sensing``.

On disk, on the command line and in ``gym.make`` the options stay flat keys beside the
scenario's own (``make_scenario(name, inner_rate=..., benchmark="v3")``,
``scenario_options``, ``--scenario-option``, ``Scenario.with_changes``): ``split_loop_keys``
is the one place that turns them into the record. A record is *given* (its None fields
still the benchmark's) until ``resolved`` fills them in for a vehicle and a clock; the
resolved record keeps the given one (``as_given``), so a change of benchmark resolves again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from quad_dob_env.benchmark import BENCHMARKS, LOOP_FIELDS, loop_fields
from quad_dob_env.dynamics.throttle import ThrottleMap
from quad_dob_env.params import AirframeDrag, VehicleParams, get_vehicle
from quad_dob_env.sensing.models import SensorSuite, resolve_sensing
from quad_dob_env.sensing.vibration import VibrationTones
from quad_dob_env.validation import as_finite, unknown_name_error
from quad_dob_env.variation import ModelTolerance, SensorNoise, range_bounds, value_or_range

# the options that take True, False or None (None: as the benchmark says)
SWITCHES = ("speed_motors", "thrust_uncertainty", "rotor_aerodynamics", "drag",
            "pose_latency_on_ticks")
# v3's parts given as a record, a dict of its fields, None (the benchmark's) or False (off)
RECORD_OPTIONS: dict[str, type] = {"throttle_map": ThrottleMap,
                                   "model_tolerance": ModelTolerance,
                                   "airframe_drag": AirframeDrag,
                                   "imu_vibration_tones": VibrationTones}


def _pair(value: object, name: str, what: str, strictly: bool) -> tuple[float, float]:
    """``value`` as two finite numbers (positive if ``strictly``, else >= 0)."""
    if not isinstance(value, (tuple, list, np.ndarray)) or len(value) != 2:
        raise ValueError(f"LoopOptions.{name} must be {what}, None (the benchmark's) or "
                         f"False (off), got {value!r}")
    first, second = (as_finite(v, f"LoopOptions.{name}[{k}]", 0.0, strictly=strictly)
                     for k, v in enumerate(value))
    return first, second


def _record(value: object, name: str) -> object:
    """A v3 part (``RECORD_OPTIONS``) as its record, from a dict of its fields where given
    one; None and False as they are."""
    kind = RECORD_OPTIONS[name]
    if value is None or value is False or isinstance(value, kind):
        return value
    if not isinstance(value, Mapping):
        raise ValueError(f"LoopOptions.{name} must be a {kind.__name__}, a dict of its "
                         f"fields, None (the benchmark's) or False (off), got {value!r}")
    names = [f.name for f in fields(kind)]
    for key in value:
        if key not in names:
            raise unknown_name_error(f"{kind.__name__} field", key, names)
    try:
        return kind(**value)
    except TypeError as error:  # a field without a default left out
        raise ValueError(f"LoopOptions.{name} {kind.__name__}: {error}; its fields: "
                         + ", ".join(names)) from None


# what the estimators may be told was applied (LoopOptions.estimator_wrench)
ESTIMATOR_WRENCHES = ("applied", "commanded")


@dataclass(frozen=True, kw_only=True)
class LoopOptions:
    """The vehicle loop's options (table in the module docstring); validated when made.

    ``benchmark`` and the fifteen options it sets (``LOOP_FIELDS``), v1's ``motor_lag`` and
    the margin's knobs (a lag, a slower motor, a late reading: parts of the loop too);
    ``sensors`` is no option but a flat key for ``sensing``. Made by hand or from flat keys
    (``split_loop_keys``) it is *given*: its None options are the benchmark's. ``Scenario``
    holds it ``resolved`` for its vehicle and clock.
    """

    benchmark: str = "v1"
    # What every policy reads: a preset name (``ideal``, ``mocap``, ``gnss-imu``), a
    # SensorSuite, a SensorNoise, a dict of either's fields, or None (the benchmark's; v1:
    # ideal, the true state)
    sensing: SensorSuite | SensorNoise | str | None = None
    inner_rate: float | None = None
    speed_motors: bool | None = None
    thrust_uncertainty: bool | None = None
    rotor_aerodynamics: bool | None = None
    drag: bool | None = None
    motor_time_constants: tuple[float, float] | None = None
    throttle_map: ThrottleMap | None = None
    model_tolerance: ModelTolerance | None = None
    gyro_cutoff: float | None = None
    imu_vibration: tuple[float, float] | None = None
    pose_latency_on_ticks: bool | None = None
    motor_lag: bool = False
    motor_time_constant_scale: float | tuple[float, float] = 1.0
    extra_latency: float = 0.0
    # a number, or a (low, high) range [s] drawn per episode for each vehicle
    unmodelled_pose_latency: float | tuple[float, float] = 0.0
    # the IMU's vibration (``imu_vibration``, gyroscope and accelerometer alike: one source,
    # the rotors) times this; a (low, high) range is drawn per episode for each vehicle, so
    # a recipe draws about a benchmark's own level without knowing it
    imu_vibration_scale: float | tuple[float, float] = 1.0
    # e: each rotor's true thrust coefficient is the nominal times 1 + δ_k, δ_k uniform in
    # [-e, e] per episode and rescaled to a mean of 0, so the rotors differ and their sum
    # does not (the autopilot's nominal model knows neither). Off (0) in v1-v3. 0.10 is
    # the range Molchanov et al. 2019 ("Sim-to-(Multi)-Real", IROS) randomise per motor
    # (amolchanov86/quad_sim2multireal, quadrotor_randomization.py: "assymetry" in
    # [0.9, 1.1], rescaled to a sum of 4): a design choice there, not a measurement
    rotor_thrust_mismatch: float = 0.0
    # What the estimators (the NDOB, L1, the attitude laws' rotational observers) are told
    # was applied each step: "applied", the rotors' output as the nominal model gives it
    # (k_F ω² of the true, lagged rotor speeds: v1-v3, docs/design.md), or "commanded",
    # what the autopilot sent (after its mixer's saturation, in its own thrust model's
    # newtons: before the motors' lag and the true throttle map), which is all a real
    # stack without rotor telemetry has (v4's); None: the benchmark's
    estimator_wrench: str | None = None
    # the airframe's drag in place of the vehicle preset's (v4's fitted one; None: the
    # benchmark's, the preset's own in v1-v3; False: the preset's)
    airframe_drag: AirframeDrag | None = None
    # the rotors' vibration on the accelerometer as tones through the autopilot's sampling
    # and filters (v4's; None: the benchmark's; False: none)
    imu_vibration_tones: VibrationTones | None = None
    # the record as given, kept by ``resolved`` (None: this one is as given); a change of
    # benchmark or clock resolves from it again, as a given 0 or "ideal" resolves to None
    given: LoopOptions | None = field(default=None, init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.benchmark not in BENCHMARKS:
            raise unknown_name_error("benchmark", self.benchmark, BENCHMARKS)
        checked: dict[str, Any] = {}
        for name in (*SWITCHES, "motor_lag"):
            value = getattr(self, name)
            allowed = (bool, np.bool_) if name == "motor_lag" else (bool, np.bool_, type(None))
            if not isinstance(value, allowed):
                raise ValueError(f"LoopOptions.{name} must be True or False"
                                 + ("" if name == "motor_lag" else
                                    " (None: as the benchmark says)") + f", got {value!r}")
        # a name is checked here and resolved after the benchmark ("ideal" given is kept:
        # it holds under v2, where None would take v2's mocap)
        sensing = resolve_sensing(self.sensing)
        if not isinstance(self.sensing, str):
            checked["sensing"] = sensing
        if self.inner_rate is not None:
            checked["inner_rate"] = as_finite(self.inner_rate, "LoopOptions.inner_rate", 0.0)
        for name in RECORD_OPTIONS:
            checked[name] = _record(getattr(self, name), name)
        if self.motor_time_constants is not None and self.motor_time_constants is not False:
            checked["motor_time_constants"] = _pair(
                self.motor_time_constants, "motor_time_constants",
                "(spin-up, spin-down) in seconds", strictly=True)
        if self.imu_vibration is not None and self.imu_vibration is not False:
            checked["imu_vibration"] = _pair(
                self.imu_vibration, "imu_vibration",
                "(gyroscope [rad/s], accelerometer [m/s²]) RMS", strictly=False)
        if self.gyro_cutoff is not None and self.gyro_cutoff is not False:
            checked["gyro_cutoff"] = as_finite(self.gyro_cutoff, "LoopOptions.gyro_cutoff", 0.0)
        scale = value_or_range(self.motor_time_constant_scale,
                               "LoopOptions.motor_time_constant_scale",
                               "a factor on the rotors' time constants")
        if range_bounds(scale)[0] <= 0.0:
            raise ValueError(f"LoopOptions.motor_time_constant_scale must be > 0 (a motor with "
                             f"no lag is motor_lag=False), got {scale!r}")
        checked["motor_time_constant_scale"] = scale
        checked["extra_latency"] = as_finite(self.extra_latency, "LoopOptions.extra_latency",
                                             0.0)
        checked["unmodelled_pose_latency"] = value_or_range(
            self.unmodelled_pose_latency, "LoopOptions.unmodelled_pose_latency",
            "a latency in seconds")
        checked["imu_vibration_scale"] = value_or_range(
            self.imu_vibration_scale, "LoopOptions.imu_vibration_scale",
            "a factor on imu_vibration")
        mismatch = as_finite(self.rotor_thrust_mismatch, "LoopOptions.rotor_thrust_mismatch",
                             0.0)
        if mismatch >= 0.5:
            raise ValueError(f"LoopOptions.rotor_thrust_mismatch is a rotor's relative "
                             f"thrust error bound, in [0, 0.5), got {mismatch!r}")
        checked["rotor_thrust_mismatch"] = mismatch
        if self.estimator_wrench is not None and self.estimator_wrench not in (
                ESTIMATOR_WRENCHES):
            raise unknown_name_error("LoopOptions.estimator_wrench", self.estimator_wrench,
                                     ESTIMATOR_WRENCHES)
        for name, value in checked.items():  # frozen: the normalised values, set once
            object.__setattr__(self, name, value)

    @classmethod
    def from_keys(cls, keys: Mapping[str, Any]) -> LoopOptions:
        """The record from flat keys (a config's, a gym kwarg's); an unknown key is named
        with the valid ones."""
        rest = dict(keys)
        loop = split_loop_keys(rest)
        if rest:
            raise unknown_name_error("loop option", next(iter(rest)), LOOP_KEYS)
        return loop

    @classmethod
    def preset(cls, benchmark: str, vehicle: str | VehicleParams = "paper", dt: float = 0.01,
               actuation: str = "rotors") -> LoopOptions:
        """The loop ``benchmark`` flies for ``vehicle`` at the control step ``dt``: every
        option the benchmark's (resolved)."""
        return cls(benchmark=benchmark).resolved(get_vehicle(vehicle), dt, actuation)

    def as_given(self) -> LoopOptions:
        """The record as it was given, before the benchmark filled in its None options."""
        return self if self.given is None else self.given

    def keys(self) -> dict[str, Any]:
        """The flat keys given that differ from the defaults, as a config writes them."""
        given = self.as_given()
        return {option.name: getattr(given, option.name) for option in fields(given)
                if option.init and getattr(given, option.name) != option.default}

    def with_keys(self, **keys: Any) -> LoopOptions:
        """The given record with ``keys`` changed (validated again; resolved again where a
        scenario takes it)."""
        for key in keys:
            if key not in OPTION_NAMES:
                raise unknown_name_error("loop option", key, OPTION_NAMES)
        return replace(self.as_given(), **keys)

    def resolved(self, vehicle: VehicleParams, dt: float, actuation: str = "rotors",
                 scenario: str = "") -> LoopOptions:
        """This loop flown by ``vehicle`` at the control step ``dt`` [s] with ``actuation``:
        every None option the benchmark's (``benchmark.loop_fields``), the sensing
        resolved, and the options checked against each other and the vehicle; an option
        that needs a part of the loop switched off is refused with the reason (``scenario``
        names the flight in the message)."""
        given = self.as_given()
        values = loop_fields(given.benchmark, {key: getattr(given, key) for key in LOOP_FIELDS},
                             dt, actuation, scenario, vehicle)
        values["sensing"] = resolve_sensing(values["sensing"])
        loop = replace(given, **values)
        loop.check(dt, actuation, scenario)
        object.__setattr__(loop, "given", given)
        return loop

    def check(self, dt: float, actuation: str, scenario: str = "") -> None:
        """Refuse a resolved loop whose options need a part it has switched off, or a
        clock or actuation it does not fly."""
        flight = f"scenario {scenario!r}" if scenario else "the loop"
        suite = isinstance(self.sensing, SensorSuite)
        if self.imu_vibration is not None and not suite:
            raise ValueError(f"LoopOptions.imu_vibration shakes an IMU, but {flight} senses "
                             f"{self.sensing!r}: give sensing a suite with an IMU ('mocap', "
                             "'gnss-imu')")
        if self.imu_vibration_tones is not None:
            if not suite:
                raise ValueError(f"LoopOptions.imu_vibration_tones shake an IMU, but {flight} "
                                 f"senses {self.sensing!r}: give sensing a suite with an IMU "
                                 "('mocap', 'gnss-imu')")
            if not self.imu_vibration_tones.reading_period_fits(dt):
                raise ValueError(f"LoopOptions.imu_vibration_tones are read at the end of the "
                                 f"IMU's batches, every 1/{self.imu_vibration_tones.batch_rate:g}"
                                 f" s, but {flight} reads every {dt:g} s: use a control step "
                                 "that is a whole number of batches")
        if self.airframe_drag is not None and not self.drag:
            raise ValueError(f"LoopOptions.airframe_drag acts on the air-relative velocity, but "
                             f"{flight} flies without drag: set drag=True")
        if self.pose_latency_on_ticks and not suite:
            raise ValueError(f"LoopOptions.pose_latency_on_ticks resolves a sensor suite's pose "
                             f"latency, but {flight} senses {self.sensing!r}: give sensing a "
                             "suite ('mocap', 'gnss-imu')")
        low, high = range_bounds(self.unmodelled_pose_latency)
        if high and not suite:
            latency = f"{high:g}" if low == high else f"{low:g} to {high:g}"
            raise ValueError(f"LoopOptions.unmodelled_pose_latency ({latency} s) delays a "
                             f"sensor suite's pose fix, but {flight} senses "
                             f"{self.sensing!r}: give sensing a suite ('mocap', 'gnss-imu'), "
                             "or use extra_latency")
        if (self.imu_vibration_scale != 1.0 and self.imu_vibration is None
                and self.imu_vibration_tones is None):
            raise ValueError(f"LoopOptions.imu_vibration_scale = {self.imu_vibration_scale} "
                             f"scales the IMU's vibration, but {flight} has none: give "
                             "imu_vibration or imu_vibration_tones (or benchmark='v3')")
        if self.motor_time_constant_scale != 1.0 and not (self.motor_lag or self.speed_motors):
            scale = self.motor_time_constant_scale
            shown = scale if isinstance(scale, tuple) else f"{scale:g}"
            raise ValueError(f"LoopOptions.motor_time_constant_scale = {shown} scales the "
                             f"motor lag, but "
                             f"{flight} flies without it: set motor_lag=True (or "
                             "speed_motors=True) too")
        if self.rotor_thrust_mismatch and not (self.speed_motors or self.rotor_aerodynamics
                                               or self.thrust_uncertainty):
            raise ValueError(f"LoopOptions.rotor_thrust_mismatch acts on the rotors' own model, "
                             f"but {flight} flies without it: set speed_motors, "
                             "rotor_aerodynamics or thrust_uncertainty to True (or "
                             "benchmark='v2' or 'v3')")
        if self.motor_time_constants is not None and not self.speed_motors:
            raise ValueError(f"LoopOptions.motor_time_constants {self.motor_time_constants} "
                             f"are the rotor speed's, but {flight} flies without speed "
                             "motors: set speed_motors=True (or benchmark='v2')")
        for name in ("speed_motors", "thrust_uncertainty", "rotor_aerodynamics"):
            if getattr(self, name) and actuation != "rotors":
                raise ValueError(f"LoopOptions.{name} models the rotors, but {flight} flies "
                                 f"actuation={actuation!r} (the paper's wrench, no rotors): "
                                 "use actuation='rotors'")
        if self.throttle_map is not None and (not self.speed_motors
                                              or self.thrust_uncertainty):
            raise ValueError(f"LoopOptions.throttle_map maps throttle to the rotors' speed and "
                             f"replaces thrust_uncertainty's draws, but {flight} flies "
                             f"speed_motors={self.speed_motors}, thrust_uncertainty="
                             f"{self.thrust_uncertainty}: set speed_motors=True, "
                             "thrust_uncertainty=False")
        if (self.model_tolerance is not None and self.model_tolerance.thrust_coefficient
                and not self.speed_motors):
            raise ValueError(f"LoopOptions.model_tolerance's thrust coefficient is the speed "
                             f"motors' k_F, but {flight} flies without them: set "
                             "speed_motors=True, or leave its thrust_coefficient 0")
        if self.rotor_aerodynamics and not self.drag:
            raise ValueError(f"LoopOptions.rotor_aerodynamics acts on the air-relative "
                             f"velocity, but {flight} flies without drag: set drag=True")
        if self.inner_rate is not None:
            ticks = self.inner_rate * dt
            if abs(ticks - round(ticks)) > 1e-6 or round(ticks) < 1:
                raise ValueError(
                    f"LoopOptions.inner_rate must be a whole multiple of the control rate "
                    f"1/dt = {1 / dt:g} Hz (e.g. {2 / dt:g}, {4 / dt:g}), got "
                    f"{self.inner_rate!r}")
        if self.gyro_cutoff is not None:
            if self.inner_rate is None:
                raise ValueError(f"LoopOptions.gyro_cutoff filters the rates the inner loop "
                                 f"reads, but {flight} has no inner loop: set inner_rate (or "
                                 "benchmark='v2')")
            if self.gyro_cutoff >= self.inner_rate / 2:
                raise ValueError(f"LoopOptions.gyro_cutoff must be below the inner loop's "
                                 f"Nyquist frequency, {self.inner_rate / 2:g} Hz, got "
                                 f"{self.gyro_cutoff:g}")

    def airframe(self, vehicle: VehicleParams) -> VehicleParams:
        """The airframe the physics flies: ``vehicle`` with this loop's ``airframe_drag``
        in place of its own where it has one."""
        return vehicle if self.airframe_drag is None else self.airframe_drag.on(vehicle)

    def inner_ticks(self, dt: float) -> int:
        """Inner-loop ticks per control step of ``dt`` [s] (1 without an inner loop)."""
        return 1 if self.inner_rate is None else round(self.inner_rate * dt)

    def rotor_time_constants(self, vehicle: VehicleParams,
                             scale: float | None = None) -> tuple[float, float]:
        """[s] the actuators' time constants as flown, times ``scale`` (None: the record's
        ``motor_time_constant_scale``, which must then be a number, not a range drawn per
        episode): (spin-up, spin-down), equal but for speed motors given
        ``motor_time_constants``; (0, 0) without a lag."""
        if not (self.motor_lag or self.speed_motors):
            return 0.0, 0.0
        if scale is None:
            scale = self.motor_time_constant_scale
            if isinstance(scale, tuple):
                raise ValueError(f"LoopOptions.motor_time_constant_scale {scale} is a range "
                                 "drawn per episode: each vehicle's time constants are in "
                                 "info['sampled'] (motor_time_constant_scale)")
        up, down = ((vehicle.motor_time_constant,) * 2 if self.motor_time_constants is None
                    else self.motor_time_constants)
        return up * scale, down * scale


OPTION_NAMES = tuple(option.name for option in fields(LoopOptions) if option.init)
# the flat keys: the record's options and ``sensing``'s SensorNoise spelling
SENSORS_KEY = "sensors"
LOOP_KEYS = (*OPTION_NAMES, SENSORS_KEY)
DEFAULT_LOOP_OPTIONS = LoopOptions()


def _sensing_of_sensors(flat: dict[str, Any]) -> None:
    """``sensors`` given among ``flat`` as the ``sensing`` it spells: a SensorNoise (or a
    dict of its fields) is the sensing, unless a sensing given beside it differs; None
    leaves sensing to the benchmark unless one is given."""
    sensors = flat.pop(SENSORS_KEY)
    if sensors is None:
        flat.setdefault("sensing", None)
        return
    if isinstance(sensors, Mapping):
        names = [option.name for option in dataclasses.fields(SensorNoise)]
        for key in sensors:
            if key not in names:
                raise unknown_name_error("SensorNoise field", key, names)
        sensors = SensorNoise(**sensors)
    if not isinstance(sensors, SensorNoise):
        raise ValueError(f"sensors must be a SensorNoise, a dict of its fields or None (it is "
                         f"the sensing=SensorNoise(...) case), got {sensors!r}")
    named = resolve_sensing(flat.get("sensing"))
    if named is not None and named != sensors:
        raise ValueError(f"sensors is the sensing=SensorNoise(...) case: give one of them, "
                         f"got sensing={flat['sensing']!r} and sensors={sensors!r}")
    flat["sensing"] = sensors


def split_loop_keys(kwargs: dict[str, Any], loop: LoopOptions | None = None) -> LoopOptions:
    """The one place flat keys become the record: pops every loop key (``LOOP_KEYS``) out
    of ``kwargs`` (the rest stay the caller's) and lays them over ``loop`` as given (the
    defaults without); ``sensors`` becomes ``sensing``."""
    flat = {name: kwargs.pop(name) for name in LOOP_KEYS if name in kwargs}
    if loop is None:
        loop = DEFAULT_LOOP_OPTIONS
    if not isinstance(loop, LoopOptions):
        raise ValueError(f"loop must be a LoopOptions (quad_dob_env.loop_options), got "
                         f"{loop!r}; or give its options as flat keys ({', '.join(LOOP_KEYS)})")
    if SENSORS_KEY in flat:
        _sensing_of_sensors(flat)
    return loop.with_keys(**flat) if flat else loop
