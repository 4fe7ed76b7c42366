"""Time-profile models: constant, window (steps), atan ramp, sinusoid, impulse.

Each carries a force vector (world frame, N), a torque vector (body frame, N m) and a wind
velocity (world frame, m/s) that its profile ``p(t)`` scales: ``d_x = force p(t)``,
``d_Ω = torque p(t)``, ``w = wind p(t)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.disturbances.base import Disturbance, Window  # noqa: F401 (its home until 2026-12-05)
from quad_dob_env.validation import as_finite, as_vector3

ZERO = (0.0, 0.0, 0.0)


def time_or_range(value: float | tuple[float, float], name: str) -> tuple[float, float]:
    """``(t, t)`` for a time, ``(low, high)`` for a range a vehicle draws from uniformly."""
    if np.ndim(value) == 0:
        return (as_finite(value, name),) * 2
    if len(value) != 2:
        raise ValueError(f"{name} must be a time or a (low, high) range, got {value!r}")
    low, high = (as_finite(v, name) for v in value)
    if high < low:
        raise ValueError(f"{name} range needs low <= high, got {value!r}")
    return low, high


class ProfileDisturbance(Disturbance):
    """A force, a torque and a wind vector scaled by one scalar profile of time."""

    def __init__(self, force: ArrayLike = ZERO, torque: ArrayLike = ZERO,
                 wind: ArrayLike = ZERO) -> None:
        name = type(self).__name__
        self.force = as_vector3(force, f"{name}.force")
        self.torque = as_vector3(torque, f"{name}.torque")
        self.wind = as_vector3(wind, f"{name}.wind")

    def profile(self, times: NDArray) -> NDArray:
        raise NotImplementedError

    def evaluate(self, times: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        scale = self.profile(times)[..., None]
        return scale * self.force, scale * self.torque, scale * self.wind

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(force={self.force.tolist()}, "
                f"torque={self.torque.tolist()}, wind={self.wind.tolist()})")


class Constant(ProfileDisturbance):
    """``d = value`` at all times (the paper's Scenario II)."""

    def profile(self, times: NDArray) -> NDArray:
        return np.ones_like(times)


class AtanRamp(ProfileDisturbance):
    """``d = value * atan(t / time_scale)``: bounded with a finite slope (paper's Scenario I)."""

    def __init__(self, force: ArrayLike = ZERO, torque: ArrayLike = ZERO,
                 wind: ArrayLike = ZERO, time_scale: float = 2.0) -> None:
        super().__init__(force, torque, wind)
        self.time_scale = as_finite(time_scale, "AtanRamp.time_scale", 0.0, strictly=True)

    def profile(self, times: NDArray) -> NDArray:
        return np.arctan(times / self.time_scale)


class Sinusoid(ProfileDisturbance):
    """``d = value * sin(2 pi frequency t + phase)``."""

    def __init__(self, force: ArrayLike = ZERO, torque: ArrayLike = ZERO,
                 wind: ArrayLike = ZERO, frequency: float = 1.0, phase: float = 0.0) -> None:
        super().__init__(force, torque, wind)
        self.frequency = as_finite(frequency, "Sinusoid.frequency", 0.0, strictly=True)
        self.phase = as_finite(phase, "Sinusoid.phase")

    def profile(self, times: NDArray) -> NDArray:
        return np.sin(2 * np.pi * self.frequency * times + self.phase)


class Impulse(Disturbance):
    """A rectangular pulse delivering ``force_impulse`` [N s] and ``torque_impulse`` [N m s].

    It lasts ``duration`` seconds from ``start``. ``start`` may be a ``(low, high)`` range:
    each vehicle then draws its own start time, uniformly, from its generator at reset.
    """

    def __init__(self, force_impulse: ArrayLike = (0.0, 0.0, 0.0),
                 torque_impulse: ArrayLike = (0.0, 0.0, 0.0),
                 start: float | tuple[float, float] = 1.0, duration: float = 0.02) -> None:
        self.force_impulse = as_vector3(force_impulse, "Impulse.force_impulse")
        self.torque_impulse = as_vector3(torque_impulse, "Impulse.torque_impulse")
        self.duration = as_finite(duration, "Impulse.duration", 0.0, strictly=True)
        self.start_range = time_or_range(start, "Impulse.start")
        self.is_random = self.start_range[1] > self.start_range[0]
        self.channels = (True, True, False)
        self.starts = np.full(1, self.start_range[0])

    def bind(self, num_vehicles: int, dt: float) -> None:
        self.starts = np.full(num_vehicles, self.start_range[0])

    def resample(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        low, high = self.start_range
        if self.is_random:
            for index, rng in zip(indices, rngs, strict=True):
                self.starts[index] = rng.uniform(low, high)

    def sampled_parameters(self, index: int) -> dict[str, float]:
        return {"impulse_start": float(self.starts[index])} if self.is_random else {}

    def evaluate(self, times: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        start = self.starts[:, None] if self.is_random else self.start_range[0]
        active = ((times >= start) & (times < start + self.duration))[..., None] / self.duration
        return (active * self.force_impulse, active * self.torque_impulse,
                np.zeros((*times.shape, 3)))

    def __repr__(self) -> str:
        return (f"Impulse(force_impulse={self.force_impulse.tolist()}, "
                f"torque_impulse={self.torque_impulse.tolist()}, start={self.start_range}, "
                f"duration={self.duration})")
