"""Confidence intervals for comparisons over seeds: percentile bootstrap of the mean; and
the vertical share of the squared error, pooled over flights (``z_share``), which
``quad-dob evaluate`` and ``quad-dob wind-tunnel`` both report; and a tracking error's size
over a window (``error_statistics``: RMS per axis and of the norm, p95, max), the one
reckoning of real and simulated logs alike.

Two policies flown on the same seeds meet the same wind and start, so their difference is
paired: the interval of the mean per-seed difference is far tighter than the two means'
intervals side by side. "Better" means that interval excludes zero.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

CONFIDENCE = 0.95
RESAMPLES = 10_000


class Interval(NamedTuple):
    mean: float
    low: float
    high: float

    def excludes_zero(self) -> bool:
        return self.low > 0.0 or self.high < 0.0


def bootstrap_mean(values: ArrayLike, confidence: float = CONFIDENCE,
                   resamples: int = RESAMPLES, seed: int = 0) -> Interval:
    """The mean of ``values`` with its percentile-bootstrap interval (Efron 1979): the
    ``(1 ± confidence)/2`` quantiles of the means of ``resamples`` resamples with
    replacement. Seeded, so a report's intervals are reproducible."""
    data = np.asarray(values, dtype=float).reshape(-1)
    if data.size == 0 or not np.all(np.isfinite(data)):
        raise ValueError(f"bootstrap_mean needs one or more finite values, got {data!r}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    rng = np.random.default_rng(seed)
    means = data[rng.integers(0, data.size, size=(resamples, data.size))].mean(axis=1)
    tail = (1.0 - confidence) / 2.0
    low, high = np.quantile(means, [tail, 1.0 - tail])
    return Interval(float(data.mean()), float(low), float(high))


def paired_difference(values: ArrayLike, baseline: ArrayLike, **options: float) -> Interval:
    """Mean per-seed ``values - baseline`` with its bootstrap interval (same seeds, in the
    same order)."""
    a, b = np.asarray(values, dtype=float), np.asarray(baseline, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"a paired difference needs one value per seed on both sides, got "
                         f"{a.shape} and {b.shape}")
    return bootstrap_mean(a - b, **options)


def z_share(rms: ArrayLike) -> float:
    """The vertical share of the squared position error, Σ rms_z² / Σ (rms_x² + rms_y² +
    rms_z²) over the rows of ``rms`` (per-axis RMS [m], (3,) for one flight or (F, 3) for
    F flights pooled): the axes' squares sum to the norm's. NaN where every error is zero.
    The vertical sum is added last to the others: adding non-negative numbers never rounds
    below one of them, so the share never rounds above 1 (one sum of the flattened array
    did, by 2e-16, for 20 landings straight down with no horizontal error)."""
    per_axis = (np.atleast_2d(np.asarray(rms, dtype=float)) ** 2).sum(axis=0)
    vertical = float(per_axis[2])
    total = float(per_axis[0] + per_axis[1]) + vertical
    return vertical / total if total > 0 else float("nan")


@dataclass(frozen=True)
class AxisValues:
    """One value per world axis."""

    x: float
    y: float
    z: float

    @classmethod
    def of(cls, values: NDArray) -> AxisValues:
        return cls(*(float(value) for value in values))


@dataclass(frozen=True)
class ErrorStatistics:
    """A position error's size over a window: per axis and of its norm [m]."""

    rms: AxisValues  # RMS of each axis
    rms_total: float  # RMS of |e|: the square root of the axes' mean squares summed
    p95: float  # the 95th percentile of |e|
    max: float  # the largest |e|
    samples: int


def error_statistics(error: NDArray) -> ErrorStatistics:
    """The RMS per axis and of the norm, the p95 and the max of ``error`` (T, 3): the one
    reckoning of a tracking error's size for real and simulated logs, the tunnel's
    (``wind_tunnel.flight_statistics``) and Crazyswarm2's (``real_flights``)."""
    error = np.asarray(error, dtype=float)
    if error.ndim != 2 or error.shape[1] != 3 or len(error) == 0:
        raise ValueError(f"error_statistics needs a (T, 3) error with T >= 1, got "
                         f"{error.shape}")
    rms = np.sqrt(np.mean(error**2, axis=0))
    norm = np.linalg.norm(error, axis=1)
    return ErrorStatistics(rms=AxisValues.of(rms), rms_total=float(np.sqrt(np.sum(rms**2))),
                           p95=float(np.percentile(norm, 95)), max=float(norm.max()),
                           samples=len(error))
