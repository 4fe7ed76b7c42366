"""The washout (``residual_washout`` = τ [s]): a first-order high-pass on the residual, so
the steady part of a correction is left to the base's observer.

The observer is told the command, residual included, so it never takes a residual for a
disturbance: a constant residual Δa holds the vehicle off its reference by ``m Δa / k_x``
for as long as it lasts. A trained policy's output carries such a bias, and in calm flight
that bias was the residual's whole error (docs/residual-v4.md, "Two more causes"). Washout
filters are flight control's answer to an augmentation that must not move the trim (the
yaw damper's, Stevens, Lewis & Johnson, *Aircraft Control and Simulation*, 3rd ed., ch. 4):
the flown residual is ``a_k - m_k``, with ``m_{k+1} = m_k + α (a_k - m_k)`` and
``α = 1 - exp(-dt / τ)`` (the exact discretisation of ``ṁ = (a - m) / τ``), clipped to the
residual's bounds; ``m`` starts at zero with each episode, so a step in ``a`` flies whole
and decays as ``exp(-t / τ)``.

``Washout`` holds m; ``ResidualCommand`` passes each step's residual through it, after the
authority (gate, floor fade, supervisor), as ``residual:v4`` was trained. So a residual faded
to zero flies ``-m`` for a few τ, not zero: washing out before the authority would make a
faded residual exactly zero, and needs the policy trained again.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray


class Washout:
    """The high-pass of time constant ``time_constant`` [s] for n vehicles at period ``dt``."""

    def __init__(self, n: int, dt: float, time_constant: float, size: int = 4) -> None:
        self.alpha = 1.0 - math.exp(-dt / time_constant)  # exact for ṁ = (a - m) / τ
        self.mean = np.zeros((n, size))  # m: the residual's low-pass, what is washed out

    def restart(self, indices: NDArray[np.intp]) -> None:
        """New episodes: nothing washed out yet."""
        self.mean[indices] = 0.0

    def flown(self, residual: NDArray[np.float64]) -> NDArray[np.float64]:
        """``residual`` (N, size) less its low-pass, clipped to [-1, 1]; advances the
        low-pass by one step."""
        flown = np.clip(residual - self.mean, -1.0, 1.0)
        self.mean += self.alpha * (residual - self.mean)
        return flown
