"""The trajectory interface: a template, and the batched reference values it produces."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

DERIVATIVE_ORDERS = 5  # position, velocity, acceleration, jerk, snap
REFERENCE_FIELDS = ("position", "velocity", "acceleration", "jerk", "snap", "heading",
                    "heading_rate", "heading_acceleration")  # Reference's, in order


@dataclass(frozen=True)
class Reference:
    """Desired motion for N vehicles at one instant; every field is (N, 3), world frame.

    ``heading`` is the desired body x-axis direction b1d (Lee et al. 2010) with its first
    two time derivatives, which the controller needs for Ωd and its rate.
    """

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    jerk: NDArray[np.float64]
    snap: NDArray[np.float64]
    heading: NDArray[np.float64]
    heading_rate: NDArray[np.float64]
    heading_acceleration: NDArray[np.float64]


class Trajectory:
    """A reference x_d(t) with heading b1d(t) = [cos ψ, sin ψ, 0] for a yaw angle ψ(t).

    Subclasses return the derivatives of position (orders 0..4) and of yaw (orders 0..2)
    in closed form; ``evaluate`` assembles them for a batch of times.
    """

    def position_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """(5, N, 3): x_d and its first four time derivatives at ``times`` (N,)."""
        raise NotImplementedError

    def yaw_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """(3, N): yaw ψ, ψ', ψ'' at ``times`` (N,)."""
        raise NotImplementedError

    def evaluate(self, times: ArrayLike) -> Reference:
        t = np.atleast_1d(np.asarray(times, dtype=float))
        if t.ndim != 1:
            raise ValueError(f"times must be a scalar or 1-D array, got shape {t.shape}")
        p = self.position_derivatives(t)
        yaw, yaw_rate, yaw_acceleration = self.yaw_derivatives(t)
        cos, sin, zero = np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)
        along = np.stack([cos, sin, zero], axis=-1)
        across = np.stack([-sin, cos, zero], axis=-1)
        # b1d = [cos ψ, sin ψ, 0]: b1d' = ψ' across, b1d'' = ψ'' across - ψ'^2 along
        return Reference(
            position=p[0], velocity=p[1], acceleration=p[2], jerk=p[3], snap=p[4],
            heading=along,
            heading_rate=yaw_rate[:, None] * across,
            heading_acceleration=yaw_acceleration[:, None] * across
            - (yaw_rate**2)[:, None] * along,
        )

    def table(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """``evaluate(times)`` as one (len(times), 8, 3) array, fields in ``Reference``'s
        order (``REFERENCE_FIELDS``): the layout the compiled kernels read."""
        ref = self.evaluate(times)
        return np.stack([getattr(ref, name) for name in REFERENCE_FIELDS], axis=1)

    def start_position(self) -> NDArray[np.float64]:
        return self.position_derivatives(np.zeros(1))[0, 0]
