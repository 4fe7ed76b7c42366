"""The Crazyflie 2.1's loop as Crazyswarm2's flight logs flew it (issue 59), pre-registered:
committed before the first comparison with the logs, every value with its source in
``CRAZYFLIE_LOOP_SOURCES`` (docs/real-flights.md tabulates them; the sources' reading is
docs/research/crazyflie-sources.md).

What the firmware runs (IMRCLab crazyflie-firmware ``unify-firmware``): the Lee law,
position and attitude in one, at ``ATTITUDE_RATE`` 500 Hz (``CONTROL_RATE``); a Kalman
filter fed by the mocap's position; the force and torques mixed per motor and battery-
compensated. Here:

- the control step is 2 ms, the law's rate, with no inner loop;
- ``CRAZYFLIE_SENSING``: one marker's mocap position at 100 Hz, 11 ms old and taken as
  the position now (as the firmware's Kalman filter takes it), and the Crazyflie's IMU,
  fused by the simulator's estimator (``quad_dob_env.sensing.estimator``) in place of the
  firmware's Kalman filter, its attitude the gyroscope's;
- the motors on rotor speed with the class's time constant (``crazyflie-2.1``'s), the
  rotors' aerodynamics and drag on; the thrust is what was asked (the firmware compensates
  the battery through its own fitted map, whose error has no source: not modelled);
- a payload, where a log carries one, hangs from a cable (``SuspendedPayload``).

Not modelled, each stated in docs/real-flights.md: the firmware's 80 Hz gyro low-pass (a
loop option of an inner loop here; about 4° of phase at the attitude loop's 3.7 Hz) and the
Kalman filter itself (its levelling of roll and pitch against the position fixes: here the
gyroscope's integral, a drift of about 0.1° over a flight).
Imports nothing above ``params``, ``sensing.models`` and ``disturbances``.
"""

from __future__ import annotations

import math
from typing import Any

from quad_dob_env.disturbances.payload import SuspendedPayload
from quad_dob_env.params import VEHICLES
from quad_dob_env.sensing.models import (
    G0,
    MOCAP_POSITION_STD,
    EstimatorGains,
    Imu,
    PoseSensor,
    RotorTelemetry,
    SensorSuite,
)

CONTROL_RATE = 500.0  # [Hz] the firmware's ATTITUDE_RATE, at which controller_lee runs
CONTROL_PERIOD = 1.0 / CONTROL_RATE
VEHICLE = "crazyflie-2.1"
# [s] the rotor speed's, both ways: the vehicle preset's (its source there)
MOTOR_TIME_CONSTANT = VEHICLES[VEHICLE].motor_time_constant
# Bosch BMI088 datasheet (BST-BMI088-DS001): gyroscope 0.014 °/s/√Hz, accelerometer
# 175 µg/√Hz (±3 g range); the bias walks have no datasheet figure: the mocap preset's
BMI088 = Imu(gyroscope_noise_density=math.radians(0.014),
             accelerometer_noise_density=175e-6 * G0,
             gyroscope_bias_walk=2.66e-5, accelerometer_bias_walk=4.33e-4)
# Preiss et al. 2017 (Crazyswarm): 11 ms from the mocap to the vehicle. The firmware's
# Kalman filter takes the fix as the position now (kalman_core/mm_position.c compares it with
# the state as it stands), so the whole latency is unknown to it: latency 0 known here, and
# the 11 ms as the loop's unmodelled pose latency (loop_options)
POSE_LATENCY = 0.011  # [s]
CRAZYFLIE_SENSING = SensorSuite(
    name="crazyflie-mocap",
    # one marker (Crazyswarm2's crazyflies.yaml: default_single_marker): the position alone
    pose=PoseSensor(kind="mocap-position", rate=100.0, latency=0.0,
                    position_std=MOCAP_POSITION_STD),
    imu=BMI088,
    # brushed motors without speed sensing: no controller here reads it
    rotors=RotorTelemetry(speed_std=0.0),
    estimator=EstimatorGains(position_bandwidth=10.0, attitude_bandwidth=5.0),
)
# [s] of hover at the reference's start before the log's window: Crazyswarm2's lee.py
# hovers 5 s after take-off and 5 s after its goTo before it starts the trajectory, so
# the firmware's integrals had settled (their slowest pole, 0.85 /s at logs 182-206's
# gains, leaves e^-8.5 of a start's offset after 10 s)
LEAD_IN = 10.0
# Crazyswarm2-tools ReadMe: the payload of the last experiments (logs 201-206) weighed 5 g
PAYLOAD_MASS = 0.005  # [kg]
# the vehicle that carries a payload, hook and all: logs 201-206's weight (their median
# hover thrust over g, 40.4-41.3 g, median 40.6 g) less the ReadMe's 5 g. A log's payload is
# its weight less this (5 g for 201-206; logs 182-184, whose payload no text records, weigh
# 48-55 g), and a log that weighs less than this plus half of 5 g carries none (log 178,
# 29.5 g, the bare vehicle)
PAYLOAD_VEHICLE_MASS = 0.0406 - PAYLOAD_MASS  # [kg]
# Crazyswarm2-tools model_payload.py's cable length; a log that records the payload gives
# its own (the median distance between the vehicle's and the payload's positions)
CABLE_LENGTH = 0.5  # [m]


def payload(mass: float = PAYLOAD_MASS, cable_length: float = CABLE_LENGTH,
            gravity: float = 9.81) -> SuspendedPayload:
    """The payload a Crazyswarm2 payload log carries, under the vehicle's ``gravity``."""
    return SuspendedPayload(mass=mass, cable_length=cable_length, gravity=gravity)


def loop_options() -> dict[str, Any]:
    """The loop's options, as ``LoopOptions`` fields, over Benchmark v2's rotors."""
    return {"benchmark": "v2", "sensing": CRAZYFLIE_SENSING, "inner_rate": 0.0,
            "speed_motors": True, "thrust_uncertainty": False, "rotor_aerodynamics": True,
            "drag": True, "motor_time_constants": (MOTOR_TIME_CONSTANT, MOTOR_TIME_CONSTANT),
            "unmodelled_pose_latency": POSE_LATENCY}


CRAZYFLIE_LOOP_SOURCES: dict[str, str] = {
    "control rate": "500 Hz: the firmware's ATTITUDE_RATE, at which controller_lee.c runs "
                    "position and attitude (RATE_DO_EXECUTE(ATTITUDE_RATE, tick))",
    "inner loop": "none: the Lee law is one function at 500 Hz",
    "pose rate": "100 Hz: Crazyswarm2 forwards each mocap frame as extPose (80-120 Hz here)",
    "pose latency": "11 ms: Preiss et al. 2017 (Crazyswarm), mocap to vehicle; unknown to the "
                    "estimator, as the firmware's Kalman filter takes the fix as the position "
                    "now (kalman_core/mm_position.c)",
    "pose": "one marker's position (crazyflies.yaml: default_single_marker), the mocap "
            "preset's 0.74 mm noise; no attitude",
    "imu": "Bosch BMI088 datasheet: gyroscope 0.014 °/s/√Hz, accelerometer 175 µg/√Hz",
    "estimator": "the simulator's complementary filter at the mocap preset's bandwidths, in "
                 "place of the firmware's Kalman filter",
    "motors": "rotor speed, 72 ms both ways: the crazyflie-2.1 preset's time constant (the "
              "legacy propellers' 86 ms moves every log's ratio by 0.01 or less)",
    "thrust map": "the firmware compensates the battery (motors.c): thrust as asked",
    "rotor aerodynamics, drag": "on: the crazyflie-2.1 preset's coefficients (drone-models' "
                                "drag identified in flight, Förster's k_F)",
    "payload mass": "the log's weight less the payload vehicle's 35.6 g (logs 201-206's "
                    "median weight, 40.6 g, less the ReadMe's 5 g payload); none below "
                    "38.1 g",
    "cable length": "the log's median vehicle-to-payload distance, else 0.5 m "
                    "(model_payload.py)",
    "weight": "each log's median thrustSI over its last 1.5 s (hovering, the integrals "
              "settled) over g: what the firmware's own thrust map needed to hold it",
    "lead-in": "10 s of hover before the window, as lee.py hovers before it logs",
}
