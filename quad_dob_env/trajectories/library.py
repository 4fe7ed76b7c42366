"""The trajectories that ship: paper helix, hover, circle, lemniscate, take-off/hover/landing,
waypoint hops."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.polynomial import polynomial
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.trajectories.base import DERIVATIVE_ORDERS, Trajectory
from quad_dob_env.validation import as_finite, as_vector3


def _constant_yaw(times: NDArray, yaw: float, yaw_rate: float = 0.0) -> NDArray:
    return np.stack([yaw + yaw_rate * times, np.full_like(times, yaw_rate),
                     np.zeros_like(times)])


class Harmonic(Trajectory):
    """``x_d,i(t) = offset_i + drift_i t + sum_j A_ij sin(ω_ij t + φ_ij)``, yaw ``ψ0 + ψ' t``.

    ``terms`` lists ``(axis, amplitude, angular_frequency, phase)``. Every derivative is
    closed-form: ``d^k/dt^k sin(ωt + φ) = ω^k sin(ωt + φ + kπ/2)``.
    """

    def __init__(self, offset: ArrayLike = (0.0, 0.0, 0.0), drift: ArrayLike = (0.0, 0.0, 0.0),
                 terms: Sequence[tuple[int, float, float, float]] = (), yaw: float = 0.0,
                 yaw_rate: float = 0.0) -> None:
        self.offset = as_vector3(offset, f"{type(self).__name__}.offset")
        self.drift = as_vector3(drift, f"{type(self).__name__}.drift")
        self.terms = [(int(axis), float(a), float(w), float(phase))
                      for axis, a, w, phase in terms]
        for axis, *_ in self.terms:
            if axis not in (0, 1, 2):
                raise ValueError(f"harmonic term axis must be 0, 1 or 2, got {axis}")
        self.yaw = as_finite(yaw, "yaw")
        self.yaw_rate = as_finite(yaw_rate, "yaw_rate")

    def position_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros((DERIVATIVE_ORDERS, times.shape[0], 3))
        out[0] = self.offset + times[:, None] * self.drift
        out[1] = self.drift
        for axis, amplitude, omega, phase in self.terms:
            angle = omega * times + phase
            sin, cos = amplitude * np.sin(angle), amplitude * np.cos(angle)
            # orders 0..4 of sin: sin, cos, -sin, -cos, sin, each times ω^k
            for order, value in enumerate((sin, cos, -sin, -cos, sin)):
                out[order, :, axis] += omega**order * value
        return out

    def yaw_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        return _constant_yaw(times, self.yaw, self.yaw_rate)


class PaperHelix(Harmonic):
    """The paper's reference: ``x_d = [0.4 t, 0.4 sin πt, altitude + 0.6 cos πt]``,
    ``b1d = [cos ψ't, sin ψ't, 0]`` with ``ψ' = yaw_rate`` (the paper: π rad/s, altitude 0).
    ``yaw_rate=0`` holds the heading along +x, the direction of travel."""

    def __init__(self, forward_speed: float = 0.4, lateral_amplitude: float = 0.4,
                 vertical_amplitude: float = 0.6, angular_frequency: float = math.pi,
                 yaw_rate: float = math.pi, altitude: float = 0.0) -> None:
        w = as_finite(angular_frequency, "PaperHelix.angular_frequency", 0.0, strictly=True)
        super().__init__(
            offset=(0.0, 0.0, as_finite(altitude, "PaperHelix.altitude")),
            drift=(forward_speed, 0.0, 0.0),
            terms=[(1, lateral_amplitude, w, 0.0), (2, vertical_amplitude, w, math.pi / 2)],
            yaw=0.0, yaw_rate=yaw_rate,
        )


class Hover(Harmonic):
    """Stay at ``position`` facing ``yaw``."""

    def __init__(self, position: ArrayLike = (0.0, 0.0, 1.0), yaw: float = 0.0) -> None:
        super().__init__(offset=position, yaw=yaw)


class Circle(Harmonic):
    """A horizontal circle of ``radius`` about ``center`` in ``period`` seconds, fixed heading."""

    def __init__(self, center: ArrayLike = (0.0, 0.0, 1.0), radius: float = 1.0,
                 period: float = 5.0, yaw: float = 0.0) -> None:
        as_finite(radius, "Circle.radius", 0.0, strictly=True)
        w = 2 * math.pi / as_finite(period, "Circle.period", 0.0, strictly=True)
        super().__init__(offset=center, yaw=yaw,
                         terms=[(0, radius, w, math.pi / 2), (1, radius, w, 0.0)])


class Lemniscate(Harmonic):
    """Figure eight (lemniscate of Gerono): ``x = a sin ωt``, ``y = (a/2) sin 2ωt``."""

    def __init__(self, center: ArrayLike = (0.0, 0.0, 1.0), amplitude: float = 1.0,
                 period: float = 8.0, yaw: float = 0.0) -> None:
        as_finite(amplitude, "Lemniscate.amplitude", 0.0, strictly=True)
        w = 2 * math.pi / as_finite(period, "Lemniscate.period", 0.0, strictly=True)
        super().__init__(offset=center, yaw=yaw,
                         terms=[(0, amplitude, w, 0.0), (1, amplitude / 2, 2 * w, 0.0)])


class RampedStart(Trajectory):
    """``base`` flown on a clock that starts from rest: ``x_d(t) = base(φ(t))`` with the
    clock's rate ``φ' = t / T`` for t < T and 1 after, so ``φ = t² / (2T)``, then
    ``t - T/2`` (continuous, and at rest at t = 0). ``ramp_time`` T [s]; 0 is ``base``
    itself.

    The derivatives are the chain rule's (Faà di Bruno's formula, with φ''' = 0), ``b_k``
    the base's k-th derivative at φ: ``x' = b1 φ'``, ``x'' = b2 φ'² + b1 φ''``, the third
    ``b3 φ'³ + 3 b2 φ' φ''``, the fourth ``b4 φ'⁴ + 6 b3 φ'² φ'' + 3 b2 φ''²``; the yaw's
    alike. φ'' steps from 1/T to 0 at T, and the acceleration with it by ``b1 / T``, as a
    reference whose rate ramps linearly does.
    """

    def __init__(self, base: Trajectory, ramp_time: float) -> None:
        self.base = base
        self.ramp_time = as_finite(ramp_time, "RampedStart.ramp_time", 0.0)

    def _clock(self, times: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        """φ, φ', φ'' at ``times``."""
        ramp = self.ramp_time
        if ramp == 0:
            return times, np.ones_like(times), np.zeros_like(times)
        during = times < ramp
        phase = np.where(during, times ** 2 / (2 * ramp), times - ramp / 2)
        return phase, np.where(during, times / ramp, 1.0), np.where(during, 1.0 / ramp, 0.0)

    def position_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        phase, rate, change = self._clock(times)
        b = self.base.position_derivatives(phase)
        r, c = rate[:, None], change[:, None]
        out = np.empty_like(b)
        out[0] = b[0]
        out[1] = b[1] * r
        out[2] = b[2] * r ** 2 + b[1] * c
        out[3] = b[3] * r ** 3 + 3 * b[2] * r * c
        out[4] = b[4] * r ** 4 + 6 * b[3] * r ** 2 * c + 3 * b[2] * c ** 2
        return out

    def yaw_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        phase, rate, change = self._clock(times)
        yaw = self.base.yaw_derivatives(phase)
        return np.stack([yaw[0], yaw[1] * rate, yaw[2] * rate ** 2 + yaw[1] * change])


# s(τ) = 35τ⁴ - 84τ⁵ + 70τ⁶ - 20τ⁷: 0 -> 1 on [0, 1] with zero 1st..3rd derivatives at both ends
_SMOOTHSTEP = np.array([0, 0, 0, 0, 35.0, -84.0, 70.0, -20.0])
_SMOOTHSTEP_DERIVATIVES = [polynomial.polyder(_SMOOTHSTEP, k) for k in range(DERIVATIVE_ORDERS)]


class TakeoffHoverLanding(Trajectory):
    """Climb, hover, descend, then stay: a C³ vertical profile over a fixed ``(x, y)``.

    Height goes ``start_height -> hover_height`` in ``climb_time``, holds for
    ``hover_time``, then ``-> end_height`` in ``descent_time`` and holds. Each transition is
    the septic smoothstep, so velocity, acceleration and jerk are continuous.
    """

    def __init__(self, xy: ArrayLike = (0.0, 0.0), start_height: float = 0.0,
                 hover_height: float = 1.0, end_height: float = 0.0, climb_time: float = 2.0,
                 hover_time: float = 4.0, descent_time: float = 2.0, yaw: float = 0.0) -> None:
        xy = np.asarray(xy, dtype=float)
        if xy.shape != (2,) or not np.all(np.isfinite(xy)):
            raise ValueError(f"TakeoffHoverLanding.xy must be a finite 2-vector, got {xy!r}")
        self.xy = xy
        self.heights = [as_finite(v, f"TakeoffHoverLanding.{n}") for n, v in
                        (("start_height", start_height), ("hover_height", hover_height),
                         ("end_height", end_height))]
        self.climb_time = as_finite(climb_time, "TakeoffHoverLanding.climb_time", 0.0)
        self.hover_time = as_finite(hover_time, "TakeoffHoverLanding.hover_time", 0.0)
        self.descent_time = as_finite(descent_time, "TakeoffHoverLanding.descent_time", 0.0)
        self.yaw = as_finite(yaw, "TakeoffHoverLanding.yaw")

    def position_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        start, hover, end = self.heights
        out = np.zeros((DERIVATIVE_ORDERS, times.shape[0], 3))
        out[0, :, :2] = self.xy
        descent_start = self.climb_time + self.hover_time
        height = out[0, :, 2]
        height[:] = np.where(times < self.climb_time, start, np.where(times < descent_start,
                                                                      hover, end))
        for t0, duration, z0, z1 in ((0.0, self.climb_time, start, hover),
                                     (descent_start, self.descent_time, hover, end)):
            if duration <= 0:
                continue
            inside = (times >= t0) & (times < t0 + duration)
            tau = (times[inside] - t0) / duration
            for order in range(DERIVATIVE_ORDERS):
                value = polynomial.polyval(tau, _SMOOTHSTEP_DERIVATIVES[order])
                offset = z0 if order == 0 else 0.0
                out[order, inside, 2] = offset + (z1 - z0) * value / duration**order
        return out

    def yaw_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        return _constant_yaw(times, self.yaw)


class WaypointHops(Trajectory):
    """Rest-to-rest hops through ``waypoints`` (K, 3): the reference holds ``waypoints[0]``
    until ``starts[0]``, moves to ``waypoints[1]`` in ``durations[0]``, holds, and so on, then
    holds the last. Each hop follows the septic smoothstep along the straight line, so
    velocity, acceleration and jerk are continuous (zero at every waypoint), as
    ``TakeoffHoverLanding``'s climb; heading fixed at ``yaw``. A hop of length L in T peaks
    at 35 L / (16 T) m/s and about 7.51 L / T² m/s² (the smoothstep's own maxima)."""

    def __init__(self, waypoints: ArrayLike, starts: Sequence[float],
                 durations: Sequence[float], yaw: float = 0.0) -> None:
        points = np.asarray(waypoints, dtype=float)
        if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2 \
                or not np.all(np.isfinite(points)):
            raise ValueError(f"WaypointHops.waypoints must be a finite (K, 3) array with K >= 2, "
                             f"got shape {points.shape}")
        hops = len(points) - 1
        if len(starts) != hops or len(durations) != hops:
            raise ValueError(f"WaypointHops needs one start and one duration per hop ({hops}), "
                             f"got {len(starts)} and {len(durations)}")
        self.starts = [as_finite(t, "WaypointHops.starts", 0.0) for t in starts]
        self.durations = [as_finite(t, "WaypointHops.durations", 0.0, strictly=True)
                          for t in durations]
        for k in range(1, hops):
            if self.starts[k] < self.starts[k - 1] + self.durations[k - 1]:
                raise ValueError(f"WaypointHops: hop {k} starts at {self.starts[k]:g} s, before "
                                 f"hop {k - 1} ends at "
                                 f"{self.starts[k - 1] + self.durations[k - 1]:g} s")
        self.waypoints = points
        self.yaw = as_finite(yaw, "WaypointHops.yaw")

    def position_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros((DERIVATIVE_ORDERS, times.shape[0], 3))
        out[0] = self.waypoints[0]
        for k, (t0, duration) in enumerate(zip(self.starts, self.durations, strict=True)):
            step = self.waypoints[k + 1] - self.waypoints[k]
            out[0, times >= t0 + duration] = self.waypoints[k + 1]
            inside = (times >= t0) & (times < t0 + duration)
            tau = (times[inside] - t0) / duration
            for order in range(DERIVATIVE_ORDERS):
                value = polynomial.polyval(tau, _SMOOTHSTEP_DERIVATIVES[order])
                start = self.waypoints[k] if order == 0 else 0.0
                out[order, inside] = start + np.outer(value / duration**order, step)
        return out

    def yaw_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        return _constant_yaw(times, self.yaw)
