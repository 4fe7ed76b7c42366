"""The sensing records: the sensors a vehicle carries and the estimator that fuses them,
the named presets, and where every preset number comes from.

``LoopOptions.sensing`` takes a preset name (``SENSING_PRESETS``), a ``SensorSuite``, a
``SensorNoise`` (Gaussian noise on the state itself, no estimator: what ``sensors=``
always was) or None (``ideal``: the controllers read the true state).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from quad_dob_env.params import VEHICLES
from quad_dob_env.validation import as_finite, unknown_name_error
from quad_dob_env.variation import SensorNoise

POSE_KINDS = ("mocap", "gnss", "mocap-position")
G0 = 9.80665  # standard gravity, for datasheet figures given in g


def _positive_fields(record: object, names: tuple[str, ...], strictly: bool = False) -> None:
    owner = type(record).__name__
    for name in names:
        object.__setattr__(record, name, as_finite(getattr(record, name), f"{owner}.{name}",
                                                   0.0, strictly=strictly))


@dataclass(frozen=True)
class PoseSensor:
    """An external pose fix at ``rate`` [Hz], ``latency`` [s] old when it arrives.

    ``kind="mocap"``: position and attitude, white noise of ``position_std`` [m] per axis and
    ``attitude_std`` [rad] per axis (a random rotation of that size).
    ``kind="mocap-position"``: a single marker's fix, the position alone (its attitude is
    not used: the estimator's attitude is the gyroscope's), as the Crazyflie's extPos.
    ``vertical_position_std`` [m], when given, is the vertical axis's (None: as the others).
    ``kind="gnss"``: position (``position_std`` horizontal, ``vertical_position_std``
    vertical) and velocity (``velocity_std`` [m/s] per axis) from a receiver, and a compass
    heading with ``heading_std`` [rad]; roll and pitch then come from the accelerometer
    against the acceleration the receiver's velocities show."""

    kind: str
    rate: float
    latency: float
    position_std: float
    vertical_position_std: float | None = None
    attitude_std: float = 0.0
    velocity_std: float = 0.0
    heading_std: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in POSE_KINDS:
            raise unknown_name_error("PoseSensor.kind", self.kind, POSE_KINDS)
        _positive_fields(self, ("rate",), strictly=True)
        _positive_fields(self, ("latency", "position_std", "attitude_std", "velocity_std",
                                "heading_std"))
        if self.vertical_position_std is not None:
            _positive_fields(self, ("vertical_position_std",))

    @property
    def vertical_std(self) -> float:
        """The vertical position noise [m]: ``vertical_position_std``, else the others'."""
        return (self.position_std if self.vertical_position_std is None
                else self.vertical_position_std)


@dataclass(frozen=True)
class Imu:
    """Gyroscope and accelerometer, read every control step: white noise of the given
    densities (continuous, per √Hz; a sample at period dt has std density / √dt), a bias
    that starts at a draw of ``*_initial_bias`` std per axis and walks with the
    ``*_bias_walk`` densities (std walk · √dt per step), and ``latency`` [s]."""

    gyroscope_noise_density: float  # [rad/s/√Hz]
    accelerometer_noise_density: float  # [m/s²/√Hz]
    gyroscope_bias_walk: float  # [rad/s²/√Hz]
    accelerometer_bias_walk: float  # [m/s³/√Hz]
    gyroscope_initial_bias: float = 0.0  # [rad/s]
    accelerometer_initial_bias: float = 0.0  # [m/s²]
    latency: float = 0.0  # [s]

    def __post_init__(self) -> None:
        _positive_fields(self, tuple(f.name for f in dataclasses.fields(self)))


@dataclass(frozen=True)
class RotorTelemetry:
    """Each rotor's speed as its ESC reports it, every control step: white noise of
    ``speed_std`` [rad/s] and ``latency`` [s]."""

    speed_std: float
    latency: float = 0.0

    def __post_init__(self) -> None:
        _positive_fields(self, ("speed_std", "latency"))


@dataclass(frozen=True)
class EstimatorGains:
    """The complementary filter's bandwidths [rad/s] (``quad_dob_env.sensing.estimator``).

    ``position_bandwidth`` ω_p places the position / velocity / accelerometer-bias loop's
    three poles at -ω_p; ``attitude_bandwidth`` ω_R is the attitude correction's gain,
    with the gyroscope-bias integral making a double pole at -ω_R / 2;
    ``velocity_bandwidth`` ω_v pulls the velocity to a GNSS velocity fix (unused with
    mocap). Each correction is applied when a fix arrives,
    with the gain bandwidth times the fix's period, so a bandwidth times that period must be
    at most 1."""

    position_bandwidth: float
    attitude_bandwidth: float
    velocity_bandwidth: float = 0.0

    def __post_init__(self) -> None:
        _positive_fields(self, ("position_bandwidth", "attitude_bandwidth"), strictly=True)
        _positive_fields(self, ("velocity_bandwidth",))


@dataclass(frozen=True)
class SensorSuite:
    """What a vehicle carries and how it fuses it: a pose sensor, an IMU, rotor-speed
    telemetry and the estimator's gains."""

    name: str
    pose: PoseSensor
    imu: Imu
    rotors: RotorTelemetry
    estimator: EstimatorGains

    def __post_init__(self) -> None:
        for name, kind in (("pose", PoseSensor), ("imu", Imu), ("rotors", RotorTelemetry),
                           ("estimator", EstimatorGains)):
            value = getattr(self, name)
            if isinstance(value, dict):
                value = kind(**value)
            if not isinstance(value, kind):
                raise ValueError(f"SensorSuite.{name} must be a {kind.__name__} or a dict of "
                                 f"its fields, got {value!r}")
            object.__setattr__(self, name, value)
        period = 1.0 / self.pose.rate
        gains = self.estimator
        for name in ("position_bandwidth", "attitude_bandwidth", "velocity_bandwidth"):
            if getattr(gains, name) * period > 1.0:
                raise ValueError(
                    f"SensorSuite {self.name!r}: EstimatorGains.{name} = {getattr(gains, name)}"
                    f" rad/s times the pose fix's period {period:g} s is above 1; allowed: at "
                    f"most {1.0 / period:g} rad/s at {self.pose.rate:g} Hz")


# Every number with its source in SENSING_SOURCES (a test holds each field to one).
MOCAP_POSITION_STD = 0.74e-3  # [m]
MARKER_SPAN = 2 * VEHICLES["paper"].arm_length  # [m] markers at the paper vehicle's arm tips
ICM_42688_P = Imu(gyroscope_noise_density=math.radians(2.8e-3),
                  accelerometer_noise_density=70e-6 * G0,
                  gyroscope_bias_walk=2.66e-5, accelerometer_bias_walk=4.33e-4)
POLE_PAIRS = 7  # a 14-pole outrunner, as 10-inch multirotor motors are


def _telemetry_std(hover_speed: float, pole_pairs: int = POLE_PAIRS) -> float:
    """Bidirectional DShot's rotor speed noise at ``hover_speed`` [rad/s]: the ESC sends
    the electrical period in µs as a 9-bit mantissa and 3-bit exponent, so the period's
    step is 2^e µs; the speed's step is that share of the speed, quantisation noise
    step / √12."""
    period_us = 2 * math.pi / (hover_speed * pole_pairs) * 1e6
    exponent = max(0, math.ceil(math.log2(period_us / 511)))
    return hover_speed * 2**exponent / period_us / math.sqrt(12)


# at the paper vehicle's hover: each rotor holds a quarter of the weight, 845 rad/s
ESC_TELEMETRY = RotorTelemetry(speed_std=_telemetry_std(math.sqrt(
    VEHICLES["paper"].hover_thrust / 4 / VEHICLES["paper"].thrust_coefficient)))
MOCAP = SensorSuite(
    name="mocap",
    pose=PoseSensor(kind="mocap", rate=100.0, latency=0.01, position_std=MOCAP_POSITION_STD,
                    attitude_std=math.sqrt(2) * MOCAP_POSITION_STD / MARKER_SPAN),
    imu=ICM_42688_P, rotors=ESC_TELEMETRY,
    estimator=EstimatorGains(position_bandwidth=10.0, attitude_bandwidth=5.0),
)
GNSS_IMU = SensorSuite(
    name="gnss-imu",
    # CEP -> per-axis std: CEP = 1.1774 σ for a circular normal
    pose=PoseSensor(kind="gnss", rate=10.0, latency=0.11, position_std=0.01 / 1.1774,
                    vertical_position_std=2 * 0.01 / 1.1774, velocity_std=0.05,
                    heading_std=0.05 / 0.5),
    imu=ICM_42688_P, rotors=ESC_TELEMETRY,
    estimator=EstimatorGains(position_bandwidth=2.0, attitude_bandwidth=1.0,
                             velocity_bandwidth=2.0),
)
SENSING_PRESETS: dict[str, SensorSuite | None] = {"ideal": None, "mocap": MOCAP,
                                                  "gnss-imu": GNSS_IMU}
_IMU_SOURCES = {
    "imu.gyroscope_noise_density": "TDK InvenSense ICM-42688-P datasheet DS-000347: 2.8 "
                                   "mdps/√Hz (Pixhawk 6C/6X's IMU)",
    "imu.accelerometer_noise_density": "TDK ICM-42688-P datasheet DS-000347: 70 µg/√Hz",
    "imu.gyroscope_bias_walk": "Kalibr's example IMU model (ethz-asl/kalibr imu.yaml), "
                               "2.66e-5 rad/s²/√Hz: datasheets give no bias walk (Kalibr "
                               "issue 63), it comes from Allan variance",
    "imu.accelerometer_bias_walk": "Kalibr's example IMU model, 4.33e-4 m/s³/√Hz",
    "imu.gyroscope_initial_bias": "zero: the biases are calibrated on the pad before take-off "
                                  "(the estimator starts at zero bias, converged)",
    "imu.accelerometer_initial_bias": "zero, as the gyroscope's",
    "imu.latency": "zero: the IMU is read by the flight controller itself (the ICM-42688-P "
                   "samples at up to 32 kHz)",
    "rotors.speed_std": "bidirectional DShot telemetry: a 12-bit electrical period in µs, "
                        "9-bit mantissa and 3-bit exponent (Betaflight's decoder; Betaflight "
                        "wiki, Bidirectional DSHOT); at the paper vehicle's hover, 845 rad/s "
                        "with 7 pole pairs, 1,062 µs in steps of 4 µs: a speed step of 3.2 "
                        "rad/s, quantisation noise step/√12 = 0.92 rad/s",
    "rotors.latency": "zero: the ESC answers each DShot frame about 30 µs after it "
                      "(Betaflight wiki, Bidirectional DSHOT)",
}
SENSING_SOURCES: dict[str, dict[str, str]] = {
    "mocap": {
        "pose.rate": "Vicon Tracker's default 120 Hz (OptiTrack PrimeX up to 1,000 Hz), taken "
                     "at the 100 Hz control rate: one fix a step",
        "pose.latency": "Preiss et al. 2017 (Crazyswarm, Vicon Vantage): 11 ms mocap-to-vehicle "
                        "for one vehicle; Qualisys measures 6-7 ms end to end; resolved on the "
                        "10 ms control grid",
        "pose.position_std": "Krumpek et al. 2025 (arXiv 2502.21189), OptiTrack PrimeX 22: "
                             "±0.74 mm along the line of sight (±0.12 mm across), taken as "
                             "one standard deviation per axis",
        "pose.vertical_position_std": "None: as pose.position_std",
        "pose.attitude_std": "marker noise over the marker span: √2 σ_p / L with L = 0.63 m "
                             "(markers at the paper vehicle's arm tips), 1.7 mrad",
        "pose.velocity_std": "unused: motion capture gives no velocity",
        "pose.heading_std": "unused: the attitude fix holds the heading",
        **_IMU_SOURCES,
        "estimator.position_bandwidth": "our design: 10 rad/s, a decade below the 100 Hz fixes",
        "estimator.attitude_bandwidth": "our design: 5 rad/s, above the attitude loop's "
                                        "disturbances, below the fix rate",
        "estimator.velocity_bandwidth": "unused: no velocity fix",
    },
    "gnss-imu": {
        "pose.rate": "10 Hz, within u-blox ZED-F9P's RTK navigation rate (the ZED-F9R manual "
                     "gives 0-30 Hz output)",
        "pose.latency": "PX4's EKF2_GPS_DELAY default, 110 ms (an estimator setting for a "
                        "typical receiver: no vendor figure found)",
        "pose.position_std": "u-blox F9 RTK, 0.01 m + 1 ppm CEP horizontal (ZED-F9R integration "
                             "manual UBX-20039643 §2.1.4): σ = CEP / 1.1774 = 8.5 mm per axis",
        "pose.vertical_position_std": "twice the horizontal: GNSS vertical errors run 1.5-2x "
                                      "the horizontal (the F9P datasheet's vertical figure was "
                                      "not in our sources)",
        "pose.attitude_std": "unused: GNSS gives no attitude (roll and pitch come from the "
                             "accelerometer, the heading from the compass)",
        "pose.velocity_std": "0.05 m/s, u-blox F9's velocity accuracy (datasheet figure, not "
                             "retrieved from our sources)",
        "pose.heading_std": "PX4's EKF2_MAG_NOISE default 0.05 gauss over a 0.5 gauss field: "
                            "0.1 rad",
        **_IMU_SOURCES,
        "estimator.position_bandwidth": "our design: 2 rad/s, a fifth of the 10 Hz fix rate",
        "estimator.attitude_bandwidth": "our design: 1 rad/s, slow enough to average the "
                                        "compass and the levelling",
        "estimator.velocity_bandwidth": "our design: 2 rad/s, as the position's",
    },
}


def resolve_sensing(value: object) -> SensorSuite | SensorNoise | None:
    """What ``LoopOptions.sensing`` holds for ``value``: a preset's suite by name (None for
    ``ideal``), a suite or ``SensorNoise`` as given, or one built from a dict of its fields
    (a dict with ``pose`` is a ``SensorSuite``, else a ``SensorNoise``)."""
    if value is None or isinstance(value, (SensorSuite, SensorNoise)):
        return value
    if isinstance(value, str):
        if value not in SENSING_PRESETS:
            raise unknown_name_error("sensing preset", value, SENSING_PRESETS)
        return SENSING_PRESETS[value]
    if isinstance(value, dict):
        kind = SensorSuite if "pose" in value else SensorNoise
        fields_ = [f.name for f in dataclasses.fields(kind)]
        for key in value:
            if key not in fields_:
                raise unknown_name_error(f"{kind.__name__} field", key, fields_)
        try:
            return kind(**value)
        except TypeError as error:  # a field missing, here or in a part's dict
            raise ValueError(f"LoopOptions.sensing {kind.__name__}: {error}; its fields: "
                             + ", ".join(fields_)) from None
    raise ValueError(f"LoopOptions.sensing must be a preset name ({', '.join(SENSING_PRESETS)}), "
                     f"a SensorSuite, a SensorNoise, a dict of either's fields or None, got "
                     f"{value!r}")
