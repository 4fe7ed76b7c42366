"""``AuthorityGate``: how much of its residual a ``ResidualCommand`` may fly, by the
disturbance the base's observer sees; a factor in [0, 1] on the clipped residual (the floor
fade, ``floor_fade``, multiplies it).

The gate (``authority_gate`` = g, a fraction of the weight) gives ``clip(2 s / g - 1, 0, 1)``:
below half the gate the residual has no authority and the base flies alone, bit for bit;
from the gate up it has all of it. ``authority_signal`` says what ``s`` is:

- ``"force"`` (v1's): ``‖d̂x‖ / (m g₀)``, the force disturbance the observer sees now (the
  observation's entries 4-6). In Benchmark v2's calm hover a gate of 0.02 on it was open
  on 75-93 % of the steps: the per-episode thrust coefficient puts about 2 % of the weight
  into the vertical estimate even on the true state, and sensor noise adds to it
  (``benchmarks/gate_under_noise.py``).
- ``"wind"``: ``‖LPF(d̂x,xy)‖ / (m g₀)``, the estimate's horizontal part through a
  first-order low-pass of ``WIND_GATE_TIME_CONSTANT`` (its state zero at each vehicle's
  start, advanced once per flown step). What wind does to a vehicle is mostly horizontal;
  a thrust coefficient's error, the battery's sag and ground effect are vertical, and the
  estimate's noise under ``mocap`` and ``gnss-imu`` is mostly faster than the filter. On
  the tuning seeds 100-109 in v2's loop, calm hover and the calm landing kept ``s`` below
  0.0018 (``mocap``) and 0.0164 (``gnss-imu``) on 99 % of the steps, while the wind
  scenarios had it above 0.012-0.07 on 90 % (docs/residual-rl.md), so a gate of 0.04
  (shut below 0.02) stays shut in calm air under both.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.residual.options import AUTHORITY_SIGNALS

__all__ = ["AUTHORITY_SIGNALS", "WIND_GATE_TIME_CONSTANT", "AuthorityGate", "gate_factor"]

# [s] the "wind" gate's low-pass: long enough to average mocap's and gnss-imu's estimate
# noise below half a 0.04 gate in calm air (module docstring), short enough to follow the
# scenarios' 1-cosine gusts, which build over about a second
WIND_GATE_TIME_CONSTANT = 0.5


def gate_factor(seen: NDArray[np.float64], gate: float) -> NDArray[np.float64]:
    """The gate's factor for the signal ``seen`` (N,) and the gate ``gate``."""
    return np.clip(2.0 * seen / gate - 1.0, 0.0, 1.0)


class AuthorityGate:
    """The gate of threshold ``gate`` (a fraction of the weight) on ``signal`` for N
    vehicles, with its state: the ``"wind"`` signal's low-pass and the last factor."""

    def __init__(self, n: int, dt: float, gate: float, signal: str) -> None:
        self.gate, self.signal = gate, signal
        # forward Euler's step of the "wind" low-pass over one control step
        self.blend = min(1.0, dt / WIND_GATE_TIME_CONSTANT)
        self.filtered = np.zeros((n, 2))  # the "wind" signal's low-passed d̂x,xy / (m g₀)

    def restart(self, indices: NDArray[np.intp]) -> None:
        self.filtered[indices] = 0.0

    def advance(self, estimate: NDArray[np.float32]) -> None:
        """Once per flown step, with the observation's d̂x / (m g₀) (N, 3) at the step's
        start: the ``"wind"`` signal's low-pass moves on (nothing for ``"force"``)."""
        if self.signal == "wind":
            self.filtered += self.blend * (estimate[:, :2] - self.filtered)

    def factor(self, estimate: NDArray[np.float32]) -> NDArray[np.float64]:
        """The factor in [0, 1] for each vehicle, from the signal it reads."""
        seen = np.linalg.norm(self.filtered if self.signal == "wind" else estimate,
                              axis=1)  # d̂x / (m g₀)
        return gate_factor(seen, self.gate)
