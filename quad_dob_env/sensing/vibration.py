"""The rotors' vibration on the accelerometer as tones (Benchmark v4): each rotor shakes the
airframe at its rotation frequency (an imbalance's force turning in the rotor's plane) and
at its blade-pass frequency (the thrust pulsing once a blade), and the autopilot's IMU chain
leaves of each tone what its sampling and filters pass.

The chain (PX4 v1.12, ``VibrationTones``' sources): the accelerometer samples at
``raw_rate``; its driver reads the FIFO at ``batch_rate`` and publishes each batch's mean;
a 2nd-order Butterworth low-pass at ``cutoff`` runs on those means; the reading is the
filtered value at its instant. A tone ``sin θ(t)`` at frequency f leaves
``|G(f)| sin(θ(t) + arg G(f))`` with ``G = B(f) H(e^{j2πf/batch_rate})`` (``tone_gain``):
B the batch mean's response, H the filter's. Read once a control step, the tone then
appears at its alias ``|f - k/dt|``: the readings are samples of it, nothing more is
needed. ``tests/test_vibration_tones.py`` holds the form to a brute-force simulation of
the chain at the raw rate.

The rotor angle θ advances by the rotor's speed over each step (its true speed, from the
applied thrust ``k_F ω²``), from a phase drawn per episode. Imports nothing above
``quad_dob_env.filters`` and ``validation``.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.filters import butterworth_coefficients
from quad_dob_env.validation import as_finite

# the table's resolution [Hz]: between its rows the gain is interpolated linearly
TABLE_STEP = 0.25


@dataclass(frozen=True)
class VibrationTones:
    """The tones' levels and the IMU chain they pass (SI units; v4's values and their
    sources in ``quad_dob_env.benchmark_v4``).

    - ``rotor_level`` [m/s², RMS per axis]: the raw accelerometer's vibration at the rotors'
      rotation frequency, in body x and y (an imbalance's force turns in the rotor plane);
    - ``blade_pass_level`` [m/s², RMS]: at ``blades`` times it, along body z (the thrust's
      pulse per blade);
    - each is the four rotors' together, of independent phases: a rotor's amplitude is
      ``level / √2``;
    - ``raw_rate``, ``batch_rate`` [Hz]: the accelerometer's sample rate, and the rate at
      which its driver publishes each FIFO batch's mean (a whole divisor of it);
    - ``cutoff`` [Hz]: the 2nd-order Butterworth low-pass on the batches (0: none).
    """

    rotor_level: float = 0.0
    blade_pass_level: float = 0.0
    blades: int = 2
    raw_rate: float = 4000.0
    batch_rate: float = 400.0
    cutoff: float = 30.0

    def __post_init__(self) -> None:
        for name in ("rotor_level", "blade_pass_level", "cutoff"):
            object.__setattr__(self, name, as_finite(getattr(self, name),
                                                     f"VibrationTones.{name}", 0.0))
        for name in ("raw_rate", "batch_rate"):
            object.__setattr__(self, name, as_finite(getattr(self, name),
                                                     f"VibrationTones.{name}", 0.0,
                                                     strictly=True))
        if not isinstance(self.blades, (int, np.integer)) or self.blades < 1:
            raise ValueError(f"VibrationTones.blades is a propeller's blade count, a whole "
                             f"number >= 1, got {self.blades!r}")
        ratio = self.raw_rate / self.batch_rate
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(f"VibrationTones.batch_rate must divide raw_rate into whole "
                             f"batches (raw_rate {self.raw_rate:g} Hz), got "
                             f"{self.batch_rate:g} Hz")
        if self.cutoff >= self.batch_rate / 2:
            raise ValueError(f"VibrationTones.cutoff must be below the batches' Nyquist "
                             f"frequency, {self.batch_rate / 2:g} Hz, got {self.cutoff:g}")

    @property
    def batch(self) -> int:
        """Raw samples per batch."""
        return round(self.raw_rate / self.batch_rate)

    def reading_period_fits(self, dt: float) -> bool:
        """Whether a reading every ``dt`` [s] falls on a batch's end (the chain's form
        holds at those instants)."""
        batches = dt * self.batch_rate
        return abs(batches - round(batches)) < 1e-9 and round(batches) >= 1


def tone_gain(frequency: float, tones: VibrationTones) -> complex:
    """G(f): what the chain leaves of a tone at ``frequency`` [Hz], read at a batch's end:
    the batch mean's response times the low-pass's."""
    x = 2.0 * math.pi * frequency / tones.raw_rate
    count = tones.batch
    # the mean of the batch's samples, the newest at the reading: (1/M) Σ e^{-j m x}
    mean = sum(cmath.exp(-1j * m * x) for m in range(count)) / count
    if tones.cutoff == 0:
        return mean
    b0, b1, b2, a1, a2 = butterworth_coefficients(tones.cutoff, tones.batch_rate)
    z = cmath.exp(-2j * math.pi * frequency / tones.batch_rate)  # z⁻¹ on the batches
    return mean * (b0 + b1 * z + b2 * z * z) / (1.0 + a1 * z + a2 * z * z)


def gain_table(tones: VibrationTones, highest: float) -> NDArray[np.float64]:
    """``tone_gain`` every ``TABLE_STEP`` Hz from 0 to at least ``highest`` [Hz], as rows of
    (real, imaginary): the compiled readings interpolate it."""
    rows = math.ceil(highest / TABLE_STEP) + 2
    gains = [tone_gain(k * TABLE_STEP, tones) for k in range(rows)]
    return np.array([(g.real, g.imag) for g in gains])
