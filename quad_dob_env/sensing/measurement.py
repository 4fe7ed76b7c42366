"""``Measurement``: what every policy reads, the estimate and the raw readings beside it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.dynamics import VehicleState


@dataclass
class Measurement(VehicleState):
    """The state a controller flies on, (N, ...) arrays, and the readings it came from.

    ``position``, ``velocity``, ``rotation`` and ``angular_velocity`` are the estimate
    (world frame; body rates in the body frame): with ``ideal`` sensing the true state
    itself, else the state estimator's output, or the noisy, delayed state of
    ``SensorNoise``. ``gyroscope`` [rad/s] and ``accelerometer`` [m/s², specific force,
    body frame] are the newest IMU reading the vehicle has, ``rotor_speeds`` [rad/s] the
    ESCs' newest telemetry; methods such as INDI read them. Being a ``VehicleState``, it is
    what ``Controller.compute`` and ``Controller.applied`` take as their ``state``.
    """

    gyroscope: NDArray[np.float64] | None = None
    accelerometer: NDArray[np.float64] | None = None
    rotor_speeds: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        n = self.n
        for name, width in (("gyroscope", 3), ("accelerometer", 3), ("rotor_speeds", 4)):
            value = getattr(self, name)
            value = np.zeros((n, width)) if value is None else np.ascontiguousarray(
                value, dtype=np.float64)
            if value.shape != (n, width):
                raise ValueError(f"Measurement.{name} must have shape (N, {width}) with the "
                                 f"state's N = {n}, got {value.shape}")
            setattr(self, name, value)

    def copy(self) -> Measurement:
        copied = object.__new__(Measurement)  # already valid: skip __post_init__'s checks
        for name in ("position", "velocity", "rotation", "angular_velocity", "gyroscope",
                     "accelerometer", "rotor_speeds"):
            setattr(copied, name, getattr(self, name).copy())
        return copied

    @property
    def estimate(self) -> VehicleState:
        """The estimated state alone (views of this record's arrays)."""
        state = object.__new__(VehicleState)
        state.position, state.velocity = self.position, self.velocity
        state.rotation, state.angular_velocity = self.rotation, self.angular_velocity
        return state
