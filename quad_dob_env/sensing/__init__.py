"""Sensing: what every policy reads instead of the true state.

- ``models``: the records (``PoseSensor``, ``Imu``, ``RotorTelemetry``, ``EstimatorGains``,
  ``SensorSuite``), the presets ``ideal``, ``mocap`` and ``gnss-imu``
  (``SENSING_PRESETS``) with the source of every number (``SENSING_SOURCES``), and
  ``resolve_sensing``, what ``LoopOptions.sensing`` accepts.
- ``measurement``: ``Measurement``, the one record controllers read: the estimate (a
  ``VehicleState``) with the raw gyroscope, accelerometer and rotor-speed readings.
- ``sensing_pass``: the compiled readings and their delay lines, each sensor on its own
  counter-based noise stream.
- ``estimator``: the complementary filter fusing the IMU with each pose fix;
  ``stability``: the check that refuses gains whose filter would not settle at the fix
  period and lag a scenario gives it.
- ``vibration``: ``VibrationTones``, the rotors' vibration as tones, and ``tone_gain``, what
  the IMU chain's sampling and filters leave of a tone (the compiled readings add them).
- ``stage``: ``SensingStage``, which the env core runs after each step and reset.

Sits between the dynamics and the envs: may import ``params``, ``dynamics``, ``so3``,
``rng``, ``memory``, ``validation``, ``filters`` and ``variation``; never the envs, the
controllers or anything above them.
"""

from quad_dob_env.sensing.measurement import Measurement
from quad_dob_env.sensing.models import (
    SENSING_PRESETS,
    SENSING_SOURCES,
    EstimatorGains,
    Imu,
    PoseSensor,
    RotorTelemetry,
    SensorSuite,
    resolve_sensing,
)
from quad_dob_env.sensing.stage import SensingStage, delay_steps

__all__ = [
    "SENSING_PRESETS",
    "SENSING_SOURCES",
    "EstimatorGains",
    "Imu",
    "Measurement",
    "PoseSensor",
    "RotorTelemetry",
    "SensingStage",
    "SensorSuite",
    "delay_steps",
    "resolve_sensing",
]
