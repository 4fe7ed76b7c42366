"""Benchmark v4's values: v3's loop with five of its mechanisms corrected against
Neural-Fly's logs read axis by axis (issue 54), one record per vehicle preset, every value
with its source.

What changes from v3 (``quad_dob_env.benchmark_v3``), each as data here:

- the estimators (the NDOB, L1, the attitude laws' rotational observers) are told what the
  autopilot commanded, not the rotors' true output (``LoopOptions.estimator_wrench``);
  INDI, without rotor telemetry, models its actuators (``baselines.BENCHMARK_INPUTS``);
- the airframe's drag is fitted in the simulator's own tilted flight to the logs' mean
  fa_x (``AIRFRAME_DRAG``; ``training.wind_tunnel.drag_fit`` made it), in place of v3's
  untilted calibration;
- the rotors' vibration reaches the IMU as tones at the rotor and blade-pass frequencies
  through the autopilot's sampling and filters (``sensing.vibration``), in place of white
  noise;
- the throttle map's curvature is an identified thrust curve's of the class;
- the tunnel's reference starts from rest (``wind_tunnel.NEURAL_FLY_RAMP``, which
  ``figure8_wind`` flies under v4).

v4's values live here, never in the vehicle presets v1-v3 fly. ``V4_SOURCES`` says where
each number comes from and whether Neural-Fly's logs gave it; docs/benchmark-v4.md
tabulates them with the commit that pre-registered them. Imports nothing above
``benchmark_v3``, ``params`` and ``sensing.vibration``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from quad_dob_env.benchmark_v3 import REAL_LOOPS
from quad_dob_env.dynamics.throttle import ThrottleMap
from quad_dob_env.params import VEHICLES, AirframeDrag
from quad_dob_env.sensing.vibration import VibrationTones


@dataclass(frozen=True)
class V4Loop:
    """One vehicle's v4 values over its v3 record (SI units; sources in ``V4_SOURCES``)."""

    throttle_map: ThrottleMap
    airframe_drag: AirframeDrag | None  # None: the vehicle preset's own
    vibration: VibrationTones


# CTU-MRS's thrust stand (ctu-mrs/ctu-mrs.github.io, docs/100-hardware/motor_tests.md at
# a9c38dd): a T-Motor 3110 780 KV with three 11-inch propellers on a charged 4S pack, 50-100 %
# throttle. PX4's form T/T_max = (1 - κ) s + κ s², least squares with the 100 % row as
# T_max: κ = 0.601 (1147 CF), 0.659 (Tarot 1155), 0.526 (Quantum 1150), RMS 0.014-0.016 of
# full thrust. Neural-Fly's vehicle: 11-inch rotors on a 2.5 kg airframe, the same class.
_THRUST_MODEL_FACTOR = 0.60
_THROTTLE = replace(REAL_LOOPS["neural-fly"].throttle_map,
                    thrust_model_factor=_THRUST_MODEL_FACTOR)

# The drag, fitted in the simulator's own tilted equilibrium to Neural-Fly's mean fa_x at
# 4.2, 8.5 and 12.1 m/s (-3.10, -7.69, -14.66 N, each the mean of its six runs; the same
# reconstruction on both sides): `python -m quad_dob_training.wind_tunnel.drag_fit
# --neural-fly DIR` (tuning seeds 100-103, 2026-12-06). Its residuals +0.7, -5.2, +2.9 %;
# |fa_x| ∝ V^1.44, the logs' 1.44 (v3's drag in v4's loop: -2.64, -8.68, -17.38 N, V^1.77).
# The body's quadratic drag (z keeps the preset's ratio of z over x) and the rotors' k_d,
# 1.9x PX4's x500 Gazebo value (a modelling guess, not a measurement: params.py).
BODY_DRAG_Z_OVER_X = (VEHICLES["neural-fly"].drag_quadratic[2]
                      / VEHICLES["neural-fly"].drag_quadratic[0])
_FITTED_BODY_DRAG = 0.05120
_FITTED_ROTOR_DRAG = 1.5448e-4
_DRAG = AirframeDrag(body_quadratic=(_FITTED_BODY_DRAG, _FITTED_BODY_DRAG,
                                     _FITTED_BODY_DRAG * BODY_DRAG_Z_OVER_X),
                     rotor_drag_coefficient=_FITTED_ROTOR_DRAG)

# The tones' level: no tone-resolved accelerometer level of a 10-12-inch vehicle was found
# (docs/benchmark-v4.md, "Vibration"). ArduPilot's VIBE, the RMS per axis of the raw
# accelerometer above ~5 Hz (AP_InertialSensor calc_vibration_and_clipping), is "normally
# below 15 m/s²" on a 3DR IRIS (10-inch) and peaks at 30 ("Measuring Vibration"); a
# vehicle's vibration is its rotors' tones, so each axis carries that level in them: the
# rotation frequency's in x and y (a rotating imbalance), the blade pass's along z (the
# thrust's pulse). 15 m/s², both ends (0, 30) in the ablation. The chain is PX4 v1.12's
# (PX4-Autopilot v1.12.0, 9524e8e): the ICM-20689's accelerometer at 4 kHz
# (drivers/imu/invensense/icm20689), each FIFO batch's mean published at IMU_GYRO_RATEMAX,
# 400 Hz (lib/drivers/accelerometer/PX4Accelerometer.cpp), then IMU_ACCEL_CUTOFF's 30 Hz
# Butterworth (modules/sensors/vehicle_acceleration), read as its latest sample.
_VIBRATION_LEVEL = 15.0
_VIBRATION = VibrationTones(rotor_level=_VIBRATION_LEVEL, blade_pass_level=_VIBRATION_LEVEL,
                            blades=2, raw_rate=4000.0, batch_rate=400.0, cutoff=30.0)

# INDI without telemetry models its actuators to first order (baselines.BENCHMARK_INPUTS) at
# the class's measured rotor time constant, v3's (benchmark_v3: Eschmann et al. 2024's X500,
# 54 ms), as Paparazzi identifies its act_dyn on the vehicle flown. At the neural-fly
# preset's nominal 25 ms (PX4's x500 Gazebo model) the model runs twice as fast as the
# motors and INDI limit-cycles: rotors at a limit in 87 % of the steps in calm air
# (tuning seeds 100-101, docs/benchmark-v4.md).
V4_INDI_ACTUATOR_TIME_CONSTANT = REAL_LOOPS["neural-fly"].motor_time_constants[0]

V4_LOOPS: dict[str, V4Loop] = {
    "neural-fly": V4Loop(throttle_map=_THROTTLE, airframe_drag=_DRAG, vibration=_VIBRATION),
    # the paper vehicle has no tunnel to fit its drag to: its preset's own
    "paper": V4Loop(throttle_map=_THROTTLE, airframe_drag=None, vibration=_VIBRATION),
}

# Both ends of every ranged value, for the ablation (the record holds the nominal).
ABLATION_ENDS: dict[str, tuple[float, float]] = {
    "throttle_map.thrust_model_factor": (0.526, 0.659),
    "vibration.level": (0.0, 30.0),
}

V4_SOURCES: dict[str, str] = {
    "estimator_wrench": "Neural-Fly's logs hold T_sp and the motors' PWM, no rotor speed "
                        "(their columns); the estimators read the autopilot's command",
    "indi.actuator_state": "Paparazzi's INDI without RPM feedback models its actuators to "
                           "first order on the command (act_dyn; docs/research/"
                           "issue-27-indi.md [PPZ-S]); Neural-Fly's INDI vehicle had PWM only "
                           "([NF]); at v3's measured motor time constant, 54 ms (Eschmann, "
                           "Albani, Loianno 2024, a real X500)",
    "throttle_map.thrust_model_factor": "CTU-MRS thrust stand, T-Motor 3110 780 KV with "
                                        "11-inch propellers on 4S (ctu-mrs/ctu-mrs.github.io, "
                                        "docs/100-hardware/motor_tests.md, a9c38dd): PX4's "
                                        "form fitted to its 50-100 % rows, 0.526-0.659; 0.60",
    "vibration.level": "ArduPilot wiki, 'Measuring Vibration': a 3DR IRIS's (10-inch) raw "
                       "accelerometer vibration (VIBE: RMS above ~5 Hz per axis) normally "
                       "below 15 m/s², peaks to 30; no tone-resolved level of the class found: "
                       "the level in the tones, 15, ends 0 and 30",
    "vibration.blades": "2: the usual 11-inch multirotor propeller; Neural-Fly do not say "
                        "how many blades theirs have",
    "vibration.raw_rate": "PX4 v1.12 ICM-20689 driver: accelerometer at 4 kHz "
                          "(drivers/imu/invensense/icm20689/ICM20689.hpp)",
    "vibration.batch_rate": "PX4 v1.12 IMU_GYRO_RATEMAX, 400 Hz: the driver reads its FIFO and "
                            "publishes each batch's mean (PX4Accelerometer.cpp)",
    "vibration.cutoff": "PX4 v1.12 IMU_ACCEL_CUTOFF, 30 Hz, 2nd-order Butterworth on the "
                        "batches (vehicle_acceleration)",
    "airframe_drag": "fitted in the simulator's own tilted equilibrium (v4's loop, "
                     "geometric-ndob:tuned holding the figure-8's centre in steady wind) to "
                     "Neural-Fly's mean fa_x at 4.2, 8.5 and 12.1 m/s, the same reconstruction "
                     "on both sides (training/wind_tunnel/drag_fit.py): body c 0.0512 "
                     "N/(m/s)² (z 0.0853), rotor k_d 1.5448e-4 N/(rad/s·m/s)",
    "reference_ramp": "Neural-Fly's logs, the reference of all 30 tunnel runs: φ̇ = 0.0796 t "
                      "to 1 rad/s, 4π s (an input of the experiment)",
}
