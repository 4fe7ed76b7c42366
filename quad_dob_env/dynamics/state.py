"""The batched vehicle state (x, v, R, Ω) with a leading axis N."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray


class StateArrays(NamedTuple):
    """``VehicleState``'s arrays as the compiled kernels take them, read by field."""

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    rotation: NDArray[np.float64]
    angular_velocity: NDArray[np.float64]


@dataclass
class VehicleState:
    """Batched state: position (N,3), velocity (N,3), rotation (N,3,3), angular_velocity (N,3).

    Position and velocity are in the world frame, ``angular_velocity`` (Ω) in the body frame.
    """

    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    rotation: NDArray[np.float64]
    angular_velocity: NDArray[np.float64]

    def __post_init__(self) -> None:
        n = np.shape(self.position)[0] if np.ndim(self.position) == 2 else None
        shapes = {"position": (n, 3), "velocity": (n, 3), "rotation": (n, 3, 3),
                  "angular_velocity": (n, 3)}
        for name, shape in shapes.items():
            value = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            if n is None or value.shape != shape:
                raise ValueError(
                    f"VehicleState.{name} must have shape {('N', *shape[1:])} with the same N "
                    f"for every field, got {value.shape}"
                )
            setattr(self, name, value)

    def arrays(self) -> StateArrays:
        """The same arrays (not copies) as the kernels' record."""
        return StateArrays(self.position, self.velocity, self.rotation, self.angular_velocity)

    @property
    def n(self) -> int:
        return self.position.shape[0]

    @classmethod
    def at_rest(cls, n: int, position: ArrayLike = (0.0, 0.0, 0.0),
                rotation: ArrayLike | None = None) -> VehicleState:
        """N vehicles at rest at ``position`` (broadcast), level unless ``rotation`` is given."""
        rotation = np.eye(3) if rotation is None else rotation
        return cls(
            position=np.broadcast_to(np.asarray(position, dtype=float), (n, 3)).copy(),
            velocity=np.zeros((n, 3)),
            rotation=np.broadcast_to(np.asarray(rotation, dtype=float), (n, 3, 3)).copy(),
            angular_velocity=np.zeros((n, 3)),
        )

    def copy(self) -> VehicleState:
        copied = object.__new__(VehicleState)  # already valid: skip __post_init__'s checks
        copied.position, copied.velocity = self.position.copy(), self.velocity.copy()
        copied.rotation = self.rotation.copy()
        copied.angular_velocity = self.angular_velocity.copy()
        return copied

    def assign(self, other: VehicleState, indices: NDArray | slice = slice(None)) -> None:
        """Overwrite the vehicles at ``indices`` with ``other`` (in place, no reallocation)."""
        self.position[indices] = other.position
        self.velocity[indices] = other.velocity
        self.rotation[indices] = other.rotation
        self.angular_velocity[indices] = other.angular_velocity


