"""What varies from episode to episode besides the wind: state noise and domain
randomisation, both optional parts of a ``Scenario`` (the sensors and estimator of
``quad_dob_env.sensing`` are the other kind of sensing)."""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np

from quad_dob_env.validation import as_finite


def value_or_range(value: object, name: str, what: str,
                   minimum: float = 0.0) -> float | tuple[float, float]:
    """``value`` checked as a number (fixed) or a (low, high) range, drawn uniformly per
    episode (a list, as a config gives it, becomes the tuple); each at least ``minimum``."""
    if isinstance(value, (tuple, list, np.ndarray)) and len(value) == 2:
        low, high = (as_finite(v, f"{name}[{k}]", minimum) for k, v in enumerate(value))
        if high < low:
            raise ValueError(f"{name}: a range is (low, high) with low <= high, got {value!r}")
        return low, high
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be {what}: a number, or a (low, high) range drawn "
                         f"uniformly per episode, got {value!r}")
    return as_finite(value, name, minimum)


def range_bounds(value: float | tuple[float, float]) -> tuple[float, float]:
    """A ``value_or_range``'s (low, high); a number is both."""
    return value if isinstance(value, tuple) else (value, value)


@dataclass(frozen=True)
class SensorNoise:
    """What every policy reads, as ``LoopOptions.sensing`` (or ``sensors``): the true state
    with Gaussian noise of these standard deviations on the position (m), velocity (m/s),
    attitude (rad, a random rotation of that size per axis) and body rates (rad/s), taken
    each step and read ``delay_steps`` control steps late; no estimator. Reward,
    termination and ``info`` use the true state."""

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
class ModelTolerance:
    """How far the vehicle model the controllers are told may be from the truth (Benchmark
    v3): at each reset, each told value (mass, inertia, thrust coefficient) is the truth times
    a factor drawn uniformly from ``1 ± tolerance``, so the truth is the vehicle's nominal
    value over that factor; the controllers keep the nominal one. One factor scales the
    whole inertia matrix. The draws are in the reset ``info["sampled"]``."""

    mass: float = 0.0
    inertia: float = 0.0
    thrust_coefficient: float = 0.0

    def __post_init__(self) -> None:
        for name in ("mass", "inertia", "thrust_coefficient"):
            value = as_finite(getattr(self, name), f"ModelTolerance.{name}", 0.0)
            if value >= 1.0:
                raise ValueError(f"ModelTolerance.{name} is a relative bound below 1, got "
                                 f"{value!r}")
            object.__setattr__(self, name, value)
