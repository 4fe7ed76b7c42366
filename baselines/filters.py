"""Discrete low-pass filters for the estimators of ``indi`` and ``l1``, compiled per sample.

- ``butterworth_lowpass``: the second-order Butterworth section INDI filters its measured
  acceleration and actuator state with, by the bilinear transform with the cutoff
  pre-warped, ``K = tan(ω_c dt / 2)``, ``b0 = K² / (1 + √2 K + K²)``, ``b1 = 2 b0``,
  ``b2 = b0``, ``a1 = 2(K² - 1) / (·)``, ``a2 = (1 - √2 K + K²) / (·)`` (Oppenheim & Schafer,
  *Discrete-Time Signal Processing*, 3rd ed., §7.1.2; the form agilicious' and Paparazzi's
  INDI use, docs/research/issue-27-indi.md §3). Unit gain at DC, -3 dB at ω_c.
- ``first_order_lowpass``: ``C(s) = ω / (s + ω)`` discretised exactly for a held input,
  ``y_k = e^{-ω dt} y_{k-1} + (1 - e^{-ω dt}) x_k``, L1's filter on its adaptive input
  (docs/research/issue-27-l1.md §3); INDI's with ``filter_order=1`` runs the same form.
- ``NEURAL_FLY_FILTER_BANDWIDTH``: the 5 Hz of Neural-Fly's INDI and L1 (``indi-outer``,
  ``l1-matched`` in v4), from the simulator's ``quad_dob_env.filters`` (the residual's
  thrust-path input runs the same filter).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.filters import NEURAL_FLY_FILTER_BANDWIDTH
from quad_dob_env.validation import as_finite

__all__ = ["NEURAL_FLY_FILTER_BANDWIDTH", "butterworth_lowpass", "butterworth_settle",
           "butterworth_step", "first_order_lowpass"]


def butterworth_lowpass(bandwidth: float, dt: float, owner: str) -> NDArray[np.float64]:
    """(b0, b1, b2, a1, a2) of the section with cutoff ``bandwidth`` [rad/s] at period
    ``dt`` [s]; the cutoff must lie below the Nyquist rate π / dt."""
    cutoff = as_finite(bandwidth, owner, 0.0, strictly=True)
    nyquist = math.pi / dt
    if cutoff >= nyquist:
        raise ValueError(f"{owner} = {cutoff:g} rad/s is at or above the Nyquist rate "
                         f"{nyquist:.1f} rad/s of the {dt:g} s control step; allowed: below it")
    k = math.tan(cutoff * dt / 2.0)
    norm = 1.0 + math.sqrt(2.0) * k + k * k
    b0 = k * k / norm
    return np.array([b0, 2.0 * b0, b0, 2.0 * (k * k - 1.0) / norm,
                     (1.0 - math.sqrt(2.0) * k + k * k) / norm])


def first_order_lowpass(bandwidth: float, dt: float, owner: str) -> float:
    """``e^{-ω dt}``, the pole of ``ω / (s + ω)`` held over ``dt``, for ``bandwidth`` ω > 0
    [rad/s]."""
    return math.exp(-as_finite(bandwidth, owner, 0.0, strictly=True) * dt)


@njit(cache=True, inline="always")
def butterworth_step(section, value, inputs, outputs, i, k):
    """One sample ``value`` through channel k of vehicle i: ``inputs[i, :, k]`` and
    ``outputs[i, :, k]`` hold the last two inputs and outputs, newest first."""
    b0, b1, b2, a1, a2 = section[0], section[1], section[2], section[3], section[4]
    out = (b0 * value + b1 * inputs[i, 0, k] + b2 * inputs[i, 1, k]
           - a1 * outputs[i, 0, k] - a2 * outputs[i, 1, k])
    inputs[i, 1, k], inputs[i, 0, k] = inputs[i, 0, k], value
    outputs[i, 1, k], outputs[i, 0, k] = outputs[i, 0, k], out
    return out


@njit(cache=True, inline="always")
def butterworth_settle(value, inputs, outputs, i, k):
    """Channel k of vehicle i as if ``value`` had been its input for ever (its steady state:
    unit DC gain), so a filter started on a signal passes it without a transient."""
    for slot in range(2):
        inputs[i, slot, k] = value
        outputs[i, slot, k] = value
