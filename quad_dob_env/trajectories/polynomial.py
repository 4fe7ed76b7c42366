"""Piecewise polynomial references, as the Crazyflie's firmware flies them.

Each piece lasts ``duration`` seconds and holds, for x, y, z and yaw, the coefficients of a
polynomial in the time since the piece began, lowest power first (Crazyswarm2's trajectory
files: a row of duration then 8 coefficients per axis). The firmware's time scale s
stretches the whole reference, x_d(t) = p(t / s), so the k-th derivative is p⁽ᵏ⁾(t/s) / sᵏ
(bitcraze/crazyflie-firmware ``src/modules/src/pptraj.c``, which scales each piece's
duration by s and its i-th coefficient by 1/sⁱ). Before the first piece the reference is
its start, after the last its end, at rest: what the firmware holds once a trajectory
ends.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.polynomial import polynomial
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.trajectories.base import Trajectory
from quad_dob_env.validation import as_finite

AXES = 4  # x, y, z, yaw


class PiecewisePolynomial(Trajectory):
    """``pieces``: (duration [s], coefficients (4, order + 1): x, y, z, yaw, lowest power
    first); ``time_scale``: the firmware's s (> 1 flies it slower); ``offset``: added to the
    position (the firmware's relative start adds the setpoint it starts from);
    ``start_time`` [s]: when the first piece begins (before it, the start at rest)."""

    def __init__(self, pieces: Sequence[tuple[float, ArrayLike]], time_scale: float = 1.0,
                 offset: ArrayLike = (0.0, 0.0, 0.0), start_time: float = 0.0) -> None:
        if not pieces:
            raise ValueError("PiecewisePolynomial needs at least one piece")
        self.time_scale = as_finite(time_scale, "PiecewisePolynomial.time_scale", 0.0,
                                    strictly=True)
        durations, coefficients = [], []
        for index, (duration, values) in enumerate(pieces):
            durations.append(as_finite(duration, f"piece {index}'s duration", 0.0,
                                       strictly=True))
            values = np.asarray(values, dtype=float)
            if values.ndim != 2 or values.shape[0] != AXES or not np.all(np.isfinite(values)):
                raise ValueError(f"piece {index}'s coefficients must be finite, 4 rows (x, y, "
                                 f"z, yaw) of one order, got shape {values.shape}")
            coefficients.append(values)
        if len({values.shape for values in coefficients}) > 1:
            raise ValueError("every piece must have polynomials of one order")
        self.durations = np.array(durations)
        self.starts = np.concatenate([[0.0], np.cumsum(self.durations)[:-1]])
        self.coefficients = np.stack(coefficients)  # (pieces, 4, order + 1)
        self.offset = np.asarray(offset, dtype=float).reshape(3)
        self.start_time = as_finite(start_time, "PiecewisePolynomial.start_time", 0.0)
        self.duration = float(self.durations.sum()) * self.time_scale  # [s], flown

    @classmethod
    def from_csv(cls, path: str | Path, time_scale: float = 1.0,
                 offset: ArrayLike = (0.0, 0.0, 0.0), start_time: float = 0.0
                 ) -> PiecewisePolynomial:
        """A trajectory file as Crazyswarm2 writes it: rows of duration and 4 × (order + 1)
        coefficients, after an optional header row."""
        rows = [row for row in csv.reader(Path(path).read_text().splitlines()) if row]
        if rows and not _is_number(rows[0][0]):
            rows = rows[1:]
        pieces = []
        for number, row in enumerate(rows, start=1):
            values = [float(cell) for cell in row if cell.strip()]
            if len(values) < 1 + AXES or (len(values) - 1) % AXES:
                raise ValueError(f"{path}: row {number} holds {len(values)} numbers; a piece is "
                                 "a duration and the same number of coefficients for x, y, z "
                                 "and yaw")
            pieces.append((values[0], np.reshape(values[1:], (AXES, -1))))
        return cls(pieces, time_scale, offset, start_time)

    def _derivatives(self, times: NDArray, orders: int) -> NDArray:
        """(orders, N, 4): each axis's value and derivatives at the flown ``times``."""
        local = (np.asarray(times, dtype=float) - self.start_time) / self.time_scale
        total = self.starts[-1] + self.durations[-1]
        clamped = np.clip(local, 0.0, total)
        piece = np.clip(np.searchsorted(self.starts, clamped, side="right") - 1, 0,
                        len(self.durations) - 1)
        tau = clamped - self.starts[piece]
        out = np.zeros((orders, len(local), AXES))
        moving = (local >= 0.0) & (local <= total)  # at rest before and after
        for order in range(orders):
            if order and not moving.any():
                break
            for axis in range(AXES):
                derived = polynomial.polyder(self.coefficients[:, axis, :], order, axis=1)
                values = (derived[piece] * tau[:, None] ** np.arange(derived.shape[1])).sum(1)
                out[order, :, axis] = values if order == 0 else np.where(moving, values, 0.0)
            out[order] /= self.time_scale**order
        return out

    def position_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        out = self._derivatives(times, 5)[:, :, :3]
        out[0] += self.offset
        return out

    def yaw_derivatives(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        return self._derivatives(times, 3)[:, :, 3]


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False
