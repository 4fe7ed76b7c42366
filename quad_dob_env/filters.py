"""The digital filters an autopilot runs, as their coefficients: one source for the
inner loop's gyro low-pass (``envs.ticks``) and the IMU chain the vibration tones pass
(``sensing.vibration``), and Neural-Fly's 5 Hz low-pass (``NEURAL_FLY_FILTER_BANDWIDTH``:
INDI's and L1's in ``quad_dob_baselines``, the residual's thrust-path input in
``residual.loop_view``). Imports nothing of the package."""

from __future__ import annotations

import math

# [rad/s] the first-order low-pass Neural-Fly's INDI and L1 ran on their estimates, 5 Hz
# (O'Connell et al., Sci. Robot. 2022, supplement §S6; docs/research/issue-27-indi.md, [NF])
NEURAL_FLY_FILTER_BANDWIDTH = 2.0 * math.pi * 5.0


def butterworth_coefficients(cutoff: float, rate: float) -> tuple[float, ...]:
    """A 2nd-order Butterworth low-pass at ``cutoff`` [Hz] sampled at ``rate`` [Hz], by the
    bilinear transform prewarped at the cutoff (as PX4's ``LowPassFilter2p``): (b0, b1, b2,
    a1, a2) of ``y_k = b0 x_k + b1 x_{k-1} + b2 x_{k-2} - a1 y_{k-1} - a2 y_{k-2}``."""
    k = math.tan(math.pi * cutoff / rate)  # the prewarped cutoff, ω_c T / 2
    norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k * k)
    b0 = k * k * norm
    return (b0, 2.0 * b0, b0, 2.0 * (k * k - 1.0) * norm,
            (1.0 - math.sqrt(2.0) * k + k * k) * norm)
