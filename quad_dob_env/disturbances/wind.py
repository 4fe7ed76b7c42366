"""Wind: 1-cosine gusts and Dryden turbulence (MIL-F-8785C / MIL-HDBK-1797, low altitude).

Constant wind, steps and sinusoids are ``Constant(wind=...)``, ``.during(a, b)`` and
``Sinusoid(wind=...)``. Wind acts on the vehicle through its drag on the air-relative
velocity (``VehicleParams.drag_linear`` / ``drag_quadratic``), in scenarios with drag on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.disturbances.base import Disturbance
from quad_dob_env.disturbances.forces import ZERO, ProfileDisturbance, time_or_range
from quad_dob_env.linalg import discretize_noise, stationary_covariance
from quad_dob_env.rng import gaussian_pair
from quad_dob_env.threads import run_over_batch
from quad_dob_env.validation import as_finite, as_vector3, unknown_name_error

KNOT = 0.514444  # m/s
FOOT = 0.3048  # m
# MIL-F-8785C low-altitude turbulence: wind speed at 20 ft (6 m) for each intensity
DRYDEN_INTENSITIES = {"light": 15 * KNOT, "moderate": 30 * KNOT, "severe": 45 * KNOT}


class Gust(ProfileDisturbance):
    """A discrete gust of ``amplitude`` m/s along ``direction``: the MIL-F-8785C 1-cosine
    rise over ``length`` metres (crossed at ``speed`` m/s, so it lasts ``length/speed`` s)
    from ``start``, held for ``hold`` s, then the mirrored 1-cosine fall.

    ``start`` may be a ``(low, high)`` range: each vehicle then draws its own start time,
    uniformly, from its generator at reset, reported in the reset info as
    ``NAME_start`` (``name``, "gust" unless given, tells two gusts apart)."""

    def __init__(self, amplitude: float, direction: ArrayLike = (1.0, 0.0, 0.0),
                 start: float | tuple[float, float] = 1.0, length: float = 5.0,
                 speed: float = 5.0, hold: float = 0.0, name: str = "gust") -> None:
        unit = as_vector3(direction, "Gust.direction")
        if not np.linalg.norm(unit) > 0:
            raise ValueError(f"Gust.direction must be non-zero, got {direction!r}")
        super().__init__(wind=as_finite(amplitude, "Gust.amplitude") * unit / np.linalg.norm(unit))
        self.start_range = time_or_range(start, "Gust.start")
        self.start = self.start_range[0]
        self.is_random = self.start_range[1] > self.start_range[0]
        self.starts = np.full(1, self.start)
        self.name = str(name)
        self.rise = (as_finite(length, "Gust.length", 0.0, strictly=True)
                     / as_finite(speed, "Gust.speed", 0.0, strictly=True))
        self.hold = as_finite(hold, "Gust.hold", 0.0)

    def bind(self, num_vehicles: int, dt: float) -> None:
        self.starts = np.full(num_vehicles, self.start)

    def resample(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        if self.is_random:
            low, high = self.start_range
            for index, rng in zip(indices, rngs, strict=True):
                self.starts[index] = rng.uniform(low, high)

    def sampled_parameters(self, index: int) -> dict[str, float]:
        return {f"{self.name}_start": float(self.starts[index])} if self.is_random else {}

    def profile(self, times: NDArray) -> NDArray:
        # random starts: times are (N, K), one row per vehicle of the batch
        tau = times - (self.starts[:, None] if self.is_random else self.start)
        rise = 0.5 * (1 - np.cos(np.pi * np.clip(tau / self.rise, 0.0, 1.0)))
        fall_tau = tau - self.rise - self.hold
        fall = 0.5 * (1 + np.cos(np.pi * np.clip(fall_tau / self.rise, 0.0, 1.0)))
        return np.where(fall_tau > 0, fall, rise)


@njit(cache=True, nogil=True)
def _dryden_step(start, stop, state, keys, counters, transitions, noise_factors, outputs, headings,
                 scales, mean_speed, wind):
    """Add each vehicle's wind now (mean + turbulence, rotated to its heading) to every
    sample of ``wind`` (N, K, 3), then advance its filters one step."""
    turbulence = [0.0, 0.0, 0.0]
    for i in range(start, stop):
        g = [0.0] * 6
        for j in range(3):
            g[2 * j], g[2 * j + 1] = gaussian_pair(keys[i], 3 * counters[i] + j)
        counters[i] += 1
        for axis in range(3):
            x0, x1 = state[i, axis, 0], state[i, axis, 1]
            turbulence[axis] = outputs[axis, 0] * x0 + outputs[axis, 1] * x1
            t, q = transitions[axis], noise_factors[axis]
            n0, n1 = g[2 * axis], g[2 * axis + 1]
            state[i, axis, 0] = t[0, 0] * x0 + t[0, 1] * x1 + q[0, 0] * n0 + q[0, 1] * n1
            state[i, axis, 1] = t[1, 0] * x0 + t[1, 1] * x1 + q[1, 0] * n0 + q[1, 1] * n1
        scale = scales[i]
        along = scale * (turbulence[0] + mean_speed)
        across = scale * turbulence[1]
        cos, sin = math.cos(headings[i]), math.sin(headings[i])
        east = along * cos - across * sin
        north = along * sin + across * cos
        for k in range(wind.shape[1]):
            wind[i, k, 0] += east
            wind[i, k, 1] += north
            wind[i, k, 2] += scale * turbulence[2]


class Dryden(Disturbance):
    """Dryden turbulence plus the mean wind, for vehicles at ``altitude`` metres.

    MIL-F-8785C low altitude (h in feet, clamped to at least 10 ft): ``σ_w = 0.1 W20``,
    ``σ_u = σ_v = σ_w / (0.177 + 0.000823 h)^0.4``, ``L_w = h``,
    ``L_u = L_v = h / (0.177 + 0.000823 h)^1.2``; spectra
    ``H_u = σ_u √(2L_u/πV) / (1 + L_u s/V)``,
    ``H_v,w = σ √(L/πV) (1 + √3 L s/V) / (1 + L s/V)²``, with V the mean wind speed at the
    altitude, ``W20 ln(h/0.15)/ln(20/0.15)`` (floored at 1 m/s), which carries the frozen
    turbulence past the vehicle. ``wind_speed_6m`` is W20, or named by ``intensity``: it sets
    the turbulence. ``mean_wind_speed`` [m/s at the altitude], when given, sets the mean wind
    apart from it (the spec ties the two; a small vehicle is flown in light mean wind with
    turbulence of any intensity), else the log profile above gives it.
    u blows along ``direction`` (radians from +x, or None: uniform per vehicle at reset),
    v across it, w up. ``intensity_scale`` (low, high), for domain randomisation, scales
    each vehicle's mean wind and turbulence by a factor drawn uniformly at reset.

    Discretisation: each filter is sampled exactly every control step (Van Loan), with the
    output scaled so its variance is exactly σ², and started from its stationary
    distribution; the wind is held over the step. The white noise comes from a
    counter-based generator keyed per vehicle at reset, so each vehicle's turbulence
    follows from its own seed.
    """

    is_random = True
    uses_time = False  # one draw per control step, held over it
    channels = (False, False, True)

    def __init__(self, intensity: str = "moderate", wind_speed_6m: float | None = None,
                 altitude: float = 2.0, direction: float | None = 0.0,
                 mean_wind: bool = True,
                 intensity_scale: tuple[float, float] | None = None,
                 mean_wind_speed: float | None = None) -> None:
        if wind_speed_6m is None:
            if intensity not in DRYDEN_INTENSITIES:
                raise unknown_name_error("Dryden intensity", intensity, DRYDEN_INTENSITIES)
            wind_speed_6m = DRYDEN_INTENSITIES[intensity]
        self.w20 = as_finite(wind_speed_6m, "Dryden.wind_speed_6m", 0.0, strictly=True)
        self.altitude = as_finite(altitude, "Dryden.altitude", 0.0, strictly=True)
        self.direction = None if direction is None else as_finite(direction, "Dryden.direction")
        self.mean_wind = bool(mean_wind)
        self.intensity_scale = None
        if intensity_scale is not None:
            low, high = (as_finite(v, "Dryden.intensity_scale", 0.0) for v in intensity_scale)
            if high < low:
                raise ValueError(f"Dryden.intensity_scale needs low <= high, got "
                                 f"{intensity_scale!r}")
            self.intensity_scale = (low, high)
        h = max(self.altitude / FOOT, 10.0)
        scale = 0.177 + 0.000823 * h
        sigma_w = 0.1 * self.w20
        self.sigmas = np.array([sigma_w / scale**0.4, sigma_w / scale**0.4, sigma_w])
        self.lengths = np.array([h / scale**1.2, h / scale**1.2, h]) * FOOT
        self.mean_speed = (self.w20 * math.log(h / 0.15) / math.log(20 / 0.15)
                           if mean_wind_speed is None
                           else as_finite(mean_wind_speed, "Dryden.mean_wind_speed", 0.0))
        self.airspeed = max(self.mean_speed, 1.0)
        self.dt = 0.0

    def time_constants(self) -> NDArray[np.float64]:
        """``L / V`` for u, v, w [s]."""
        return self.lengths / self.airspeed

    def bind(self, num_vehicles: int, dt: float) -> None:
        self.dt = float(dt)
        transitions, factors, outputs, self._stationary = [], [], [], []
        for axis, (sigma, tau) in enumerate(zip(self.sigmas, self.time_constants(), strict=True)):
            if axis == 0:  # first order: 1 / (1 + T s)
                a, b, c = np.array([[-1 / tau, 0], [0, -1.0]]), np.array([[1.0], [0]]), [1.0, 0]
            else:  # (1 + √3 T s) / (1 + T s)²
                a = np.array([[0.0, 1.0], [-1 / tau**2, -2 / tau]])
                b, c = np.array([[0.0], [1.0]]), [1 / tau**2, math.sqrt(3) / tau]
            transition, noise = discretize_noise(a, b, self.dt)
            stationary = stationary_covariance(transition, noise)
            c = np.array(c) * sigma / math.sqrt(np.array(c) @ stationary @ np.array(c))
            factor = np.linalg.cholesky(noise + 1e-300 * np.eye(2)) if axis else np.diag(
                [math.sqrt(noise[0, 0]), 0.0])
            transitions.append(transition)
            factors.append(factor)
            outputs.append(c)
            self._stationary.append(np.linalg.cholesky(stationary + 1e-300 * np.eye(2))
                                    if axis else np.diag([math.sqrt(stationary[0, 0]), 0.0]))
        self._transitions = np.array(transitions)
        self._noise_factors = np.array(factors)
        self._outputs = np.array(outputs)
        self._state = np.zeros((num_vehicles, 3, 2))
        self._keys = np.zeros(num_vehicles, dtype=np.uint64)
        self._counters = np.zeros(num_vehicles, dtype=np.int64)
        self._headings = np.full(num_vehicles, self.direction or 0.0)
        self._scales = np.ones(num_vehicles)

    def resample(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        for index, rng in zip(indices, rngs, strict=True):
            for axis in range(3):
                self._state[index, axis] = self._stationary[axis] @ rng.standard_normal(2)
            self._keys[index] = rng.integers(0, 2**63, dtype=np.uint64)
            self._counters[index] = 0
            if self.direction is None:
                self._headings[index] = rng.uniform(0.0, 2 * math.pi)
            if self.intensity_scale is not None:
                self._scales[index] = rng.uniform(*self.intensity_scale)

    def sampled_parameters(self, index: int) -> dict[str, float]:
        return {"wind_direction": float(self._headings[index]),
                "wind_intensity_scale": float(self._scales[index])}

    def add_to(self, times: NDArray[np.float64], force: NDArray, torque: NDArray,
               wind: NDArray) -> None:
        run_over_batch(_dryden_step, len(self._state), self._state, self._keys,
                       self._counters, self._transitions, self._noise_factors, self._outputs,
                       self._headings, self._scales, self.mean_speed if self.mean_wind else 0.0,
                       wind)

    def evaluate(self, times: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        channels = tuple(np.zeros((*times.shape, 3)) for _ in range(3))
        self.add_to(times, *channels)
        return channels

    def __repr__(self) -> str:
        return (f"Dryden(W20={self.w20:.2f} m/s, mean {self.mean_speed:.2f} m/s, "
                f"altitude={self.altitude} m, direction={self.direction})")


__all__ = ["DRYDEN_INTENSITIES", "ZERO", "Dryden", "Gust"]
