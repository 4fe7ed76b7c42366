"""Benchmark v3's values: the real vehicle's lag chain, thrust path, vibration and the
controllers' model of it, one record per vehicle preset, every value with its source.

Committed before any v3 flight of the wind-tunnel figure-8s (Neural-Fly's logs are the
check, not an input): nothing here was chosen by looking at their tracking statistics.
Where a source gives a range, the record holds its nominal value (the middle where none
is named) and ``ABLATION_ENDS`` both ends. ``V3_SOURCES`` says where each number comes
from; docs/benchmark-v3.md tabulates them. A later change is listed there with its reason.
Imports nothing above ``dynamics.throttle`` and ``variation``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from quad_dob_env.dynamics.throttle import ThrottleMap
from quad_dob_env.variation import ModelTolerance


@dataclass(frozen=True)
class RealLoop:
    """One vehicle's v3 loop values (SI units; the fields' sources are in ``V3_SOURCES``)."""

    # the lag chain, command to force
    motor_time_constants: tuple[float, float]  # [s] rotor speed, (spin-up, spin-down)
    gyro_cutoff: float  # [Hz] 2nd-order Butterworth on the rates every attitude law reads
    dterm_cutoff: float  # [Hz] 2nd-order Butterworth on a rate loop's derivative term
    inner_rate: float  # [Hz] the attitude loop (PX4's IMU_INTEG_RATE)
    pose_latency: float  # [s] the mocap pipeline, exposure to estimator
    figure8_control_rate: float  # [Hz] Neural-Fly's outer loop, which the figure-8s fly
    # the throttle-to-thrust map, the autopilot's belief of it, the battery under both
    throttle_map: ThrottleMap
    # vibration on the IMU: the raw accelerometer's vibration [m/s², RMS] at the rotors'
    # hover frequency, and what the autopilot's accelerometer filter leaves of it
    accelerometer_vibration: float
    accelerometer_cutoff: float  # [Hz] 2nd-order Butterworth
    gyroscope_vibration: float  # [rad/s, RMS] raw, at the same frequency
    # the controllers' model of the vehicle
    model_tolerance: ModelTolerance
    # the wind tunnel's turbulence, σ_u / U
    tunnel_turbulence_intensity: float


# PX4 v1.12 (mid to late 2021, when Neural-Fly flew; their firmware version is not
# published): the same autopilot values for both vehicles.
_PX4_GYRO_CUTOFF, _PX4_DTERM_CUTOFF, _PX4_ACCEL_CUTOFF, _PX4_INNER_RATE = 30.0, 20.0, 30.0, 200.0
# Eschmann, Albani, Loianno 2024 (arXiv:2404.07837), a real Holybro X500 (2.0 kg, 10-inch
# propellers), identified from flight: rotor-speed time constant 54 ms rising and falling.
_MOTOR_TIME_CONSTANT = 0.054
# PX4 user guide, multicopter PID tuning, "Thrust Curve": THR_MDL_FAC typically 0.3-0.5
# (rel_thrust = factor rel_signal² + (1 - factor) rel_signal); the middle.
_THRUST_MODEL_FACTOR = 0.4
# Neural-Fly's logs (aerorobotics/neural-fly, data/experiment, all 30 runs), the
# hover_throttle channel alone: 0.444-0.504 at each run's start; its least-squares climb
# 6.9e-5 to 3.3e-4 per second (0.005-0.028 over the 50 s runs). The autopilot's pwm channel
# against its T_sp: mean pwm = 118 + 1872 T_sp, PX4's DShot map with DSHOT_MIN 0.055 and
# THR_MDL_FAC 0 (the autopilot's own configuration, read off its command channels).
_HOVER_THROTTLE, _HOVER_DRIFT = (0.444, 0.504), (6.9e-5, 3.3e-4)
_THROTTLE = ThrottleMap(thrust_model_factor=_THRUST_MODEL_FACTOR, hover_throttle=_HOVER_THROTTLE,
                        hover_throttle_drift=_HOVER_DRIFT, hover_estimate_error=0.0,
                        autopilot_thrust_model_factor=0.0)
# ArduPilot wiki, "Measuring Vibration": a 3DR IRIS (10-inch) shows normal raw accelerometer
# vibration below 15 m/s² (acceptable below 30)
_ACCELEROMETER_VIBRATION = 15.0
# O'Connell et al. 2022 give the Neural-Fly vehicle's mass as 2.53 kg (Tables S1-S2) and
# 2.6 kg (text): 2.8 % apart. Inertia from CAD: Lehmkühler et al. 2016 (Aeronautical
# Journal) needed corrections of up to 25 % on pendulum-measured UAV inertia; ±20 %.
# Thrust coefficient: air density from 0 to 30 °C at sea level, ±5 % (ISA), as v2's.
_TOLERANCE = ModelTolerance(mass=0.028, inertia=0.2, thrust_coefficient=0.05)


def butterworth_gain(frequency: float, cutoff: float) -> float:
    """|H(f)| = 1 / sqrt(1 + (f / f_c)⁴) of a 2nd-order Butterworth low-pass."""
    return 1.0 / math.sqrt(1.0 + (frequency / cutoff) ** 4)


REAL_LOOPS: dict[str, RealLoop] = {
    name: RealLoop(
        motor_time_constants=(_MOTOR_TIME_CONSTANT, _MOTOR_TIME_CONSTANT),
        gyro_cutoff=_PX4_GYRO_CUTOFF, dterm_cutoff=_PX4_DTERM_CUTOFF,
        inner_rate=_PX4_INNER_RATE, pose_latency=0.010, figure8_control_rate=50.0,
        throttle_map=_THROTTLE, accelerometer_vibration=_ACCELEROMETER_VIBRATION,
        accelerometer_cutoff=_PX4_ACCEL_CUTOFF, gyroscope_vibration=0.0,
        model_tolerance=_TOLERANCE, tunnel_turbulence_intensity=0.04)
    for name in ("paper", "neural-fly")
}

# Both ends of every ranged value, for the ablation (the record holds the nominal).
ABLATION_ENDS: dict[str, tuple[float, float]] = {
    # rl-tools' L2F domain randomisation, the same group's design bounds around its X500
    # measurement: rising 30-100 ms, falling 30-300 ms
    "motor_time_constants.up": (0.030, 0.100),
    "motor_time_constants.down": (0.030, 0.300),
    "dterm_cutoff": (0.0, 30.0),  # PX4 v1.11 had it off (0 Hz); 30 Hz from PR #16188
    "pose_latency": (0.005, 0.025),  # OptiTrack camera latency 5.6 ms; a Qualisys chain 25 ms
    "throttle_map.thrust_model_factor": (0.3, 0.5),
    "accelerometer_vibration": (0.0, 30.0),
    "tunnel_turbulence_intensity": (0.02, 0.05),
}

# The margin every v3 gain set keeps its tuning flights under (issue 40: twice v2's latency
# margin, flight-control practice's delay margin): 20 ms of latency beyond v3's own and
# slower motors, at once. v3's own latency is the mocap pipeline's, on the pose; the margin's
# sits there too, unknown to the estimator, not on the autopilot's IMU, which a real
# vehicle's attitude loop reads on board (docs/benchmark-v3.md, "The tuning margin's
# latency, on the pose").
TUNING_MARGIN = {"unmodelled_pose_latency": 0.020, "motor_time_constant_scale": 1.5}

V3_SOURCES: dict[str, str] = {
    "motor_time_constants": "Eschmann, Albani, Loianno, 'Data-Driven System Identification of "
                            "Quadrotors Subject to Motor Delays', arXiv:2404.07837 (2024): a "
                            "real Holybro X500 (2.0 kg, 10-inch), 54 ms rising and falling "
                            "(rl-tools l2f/parameters/dynamics/x500_real.h); the only measured "
                            "value of the 10-11-inch class found, used for both vehicles; no "
                            "measured spin-down of the class differs from it",
    "gyro_cutoff": "PX4 v1.12 IMU_GYRO_CUTOFF, 30 Hz, 2nd-order Butterworth on the rates the "
                   "controllers read (imu_gyro_parameters.c; lowered from 80 Hz in PR #11950 "
                   "for 'medium/large size drones')",
    "dterm_cutoff": "PX4 v1.12 IMU_DGYRO_CUTOFF, 20 Hz, 2nd-order Butterworth on the rate "
                    "loop's derivative (0 Hz in v1.11, PR #15018; 30 Hz from PR #16188)",
    "inner_rate": "PX4 IMU_INTEG_RATE, 200 Hz: the attitude estimate's and attitude loop's "
                  "rate (PR #14759, v1.11); the rate loop runs at IMU_GYRO_RATEMAX, 400 Hz",
    "pose_latency": "Preiss et al. 2017 (Crazyswarm, Vicon): 11 ms mocap to vehicle; OptiTrack "
                    "NatNet 'Latency Measurements': 5.6 ms camera latency at up to 180 Hz; "
                    "10 ms, as v2's mocap (Neural-Fly's mocap rate and latency unpublished)",
    "figure8_control_rate": "Neural-Fly's logs: T_sp and q_sp every 0.020 s (50 Hz)",
    "throttle_map.thrust_model_factor": "PX4 user guide, multicopter PID tuning, 'Thrust "
                                        "Curve': THR_MDL_FAC typically 0.3-0.5; 0.4",
    "throttle_map.autopilot_thrust_model_factor": "0, PX4's default; Neural-Fly's own "
                                                  "command channels: mean pwm = 118 + 1872 "
                                                  "T_sp over all 30 runs, PX4's linear DShot "
                                                  "map (DSHOT_MIN 0.055)",
    "throttle_map.hover_throttle": "Neural-Fly's logs, hover_throttle at each of the 30 "
                                   "runs' start: 0.444-0.504 (the autopilot's voltage-based "
                                   "estimate stands for the truth's pack-to-pack spread)",
    "throttle_map.hover_throttle_drift": "Neural-Fly's logs, hover_throttle's least-squares "
                                         "climb per run: 6.9e-5 to 3.3e-4 /s",
    "throttle_map.hover_estimate_error": "no source for the error of a voltage-based hover "
                                         "throttle estimate was found: 0, not modelled",
    "throttle_ceiling": "DShot full scale (PX4 DSHOT_MAX_THROTTLE 1999), which Neural-Fly's "
                        "pwm channel reaches in two 12.1 m/s runs: output u = 1",
    "accelerometer_vibration": "ArduPilot wiki, 'Measuring Vibration': normal raw "
                               "accelerometer vibration of a 3DR IRIS (10-inch) below 15 m/s², "
                               "acceptable below 30; at the rotors' hover frequency",
    "accelerometer_cutoff": "PX4 v1.12 IMU_ACCEL_CUTOFF, 30 Hz, 2nd-order Butterworth",
    "gyroscope_vibration": "no measured gyroscope vibration of the class was found: 0",
    "model_tolerance.mass": "O'Connell et al. 2022: 2.53 kg (Tables S1-S2) and 2.6 kg (text) "
                            "for the same vehicle, 2.8 % apart",
    "model_tolerance.inertia": "Lehmkühler, Wong, Verstraete 2016 (Aeronautical Journal): "
                               "corrections of up to 25 % on measured UAV inertia; ±20 %",
    "model_tolerance.thrust_coefficient": "air density from 0 to 30 °C at sea level (ISA), "
                                          "±5 %, as v2's thrust_uncertainty",
    "tunnel_turbulence_intensity": "no published figure for Caltech's fan array (Stefan-Zavala "
                                   "et al. 2024 say only 'more turbulent'); Neural-Fly's fa_x "
                                   "against the airspeed in the 4.2-12.1 m/s runs, its "
                                   "residual's σ over twice the mean drag with the calm runs' "
                                   "residual removed: 4.1-4.7 % (2.0-2.3 % below 2 Hz); 4 %",
    "tuning_margin": "issue 40: 20 ms of latency beyond v3's own and motor time constants "
                     "×1.5, at once",
}
