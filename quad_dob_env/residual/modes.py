"""The residual command's two modes (``residual_mode``; ``ResidualCommand`` runs them):

- ``"thrust_moments"``: the residual adds to the base's thrust and moments, scaled by
  ``thrust_scale`` and ``moment_scale`` of the limits.
- ``"acceleration"``: ``AccelerationMode``, a world-frame acceleration the base adds in its
  force law, with the guard that keeps its desired force away from zero and from steep
  tilts (``guard_correction``), and a yaw moment.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.residual.options import RESIDUAL_MODES

__all__ = ["HORIZONTAL_GUARD", "RESIDUAL_MODES", "AccelerationMode", "guard_correction"]

# how far an acceleration residual may tilt the base's desired force: tan 20°
HORIZONTAL_GUARD = float(np.tan(np.radians(20.0)))


class AccelerationMode:
    """``Δa = acceleration_scale · a₀..₂`` into the base's force law, guarded; the base is
    run by ``correct``, once, or twice where the guard changed Δa."""

    def __init__(self, controller: Any, acceleration_scale: float, vertical_floor: float,
                 mass: float, gravity: float) -> None:
        if not getattr(controller, "accepts_acceleration_correction", False):
            raise ValueError(
                f"residual_mode='acceleration' needs a base whose compute takes an "
                f"acceleration_correction (the geometric controllers: geometric, "
                f"geometric-ndob, geometric-ndob:tuned); {controller.name!r} does not")
        self.controller = controller
        self.scale, self.vertical_floor = acceleration_scale, vertical_floor
        self.mass, self.gravity = mass, gravity

    def correct(self, time: float, measurement: Any, reference: Any,
                clipped: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """The base's thrust (N,) and moments (N, 3) with the correction ``clipped[:, :3]``
        (the residual clipped to [-1, 1]); ``clipped`` takes the guarded correction."""
        correction = self.scale * clipped[:, :3]
        command = self.controller.compute(time, measurement, reference,
                                          acceleration_correction=correction)
        guarded = guard_correction(correction, self.controller.diagnostics["desired_force"],
                                   self.mass, self.gravity, self.vertical_floor)
        if guarded is not None:  # the base again, with the guarded correction
            clipped[:, :3] = guarded / self.scale
            command = self.controller.compute(time, measurement, reference,
                                              acceleration_correction=guarded)
        return command


def guard_correction(correction: NDArray[np.float64], force: NDArray[np.float64], mass: float,
                     gravity: float, vertical_floor: float) -> NDArray[np.float64] | None:
    """``correction`` (N, 3), for a base whose desired force with it is ``force`` (N, 3),
    with its downward part raised where it would take the desired force's vertical part
    below ``vertical_floor`` of the weight, and its horizontal part shortened where it
    would tilt that force by more than ``HORIZONTAL_GUARD`` (m |Δa_xy| <= tan 20° · F_z);
    None where neither applies. The force is affine in Δa (``F = F_base + m Δa``), so
    this needs the base's F once. Near F = 0 the thrust direction, and with it the
    attitude the base asks for, swings with every horizontal newton: the residual may not
    take the base there, nor swing it there, though the base may go there itself."""
    base_vertical = force[:, 2] - mass * correction[:, 2]
    floor = vertical_floor * mass * gravity
    vertical = np.maximum(correction[:, 2], np.minimum(0.0, (floor - base_vertical) / mass))
    reach = HORIZONTAL_GUARD * np.maximum(base_vertical + mass * vertical, 0.0) / mass
    horizontal = np.hypot(correction[:, 0], correction[:, 1])
    shorten = np.minimum(1.0, reach / np.maximum(horizontal, 1e-12))
    if np.all(vertical == correction[:, 2]) and np.all(shorten == 1.0):
        return None
    return np.column_stack([correction[:, :2] * shorten[:, None], vertical])
