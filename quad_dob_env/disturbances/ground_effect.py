"""Ground effect: rotors near the floor make more thrust for the same command.

Two laws, both ``T_IGE = T / (1 - c (R/h)^p)`` with rotor radius R and height h:
- ``paper``: ``T / (1 - 3R/(25h))`` (the paper, after its reference [7]); c = 3/25, p = 1.
- ``cheeseman-bennett``: ``T / (1 - (R/4h)^2)`` (Cheeseman & Bennett 1955); c = 1/16, p = 2.
Both grow without bound as h falls, so h is clamped below at ``min_height`` (default R/2,
where the two laws give 1.32 and 1.33). Above ``cutoff_height`` the effect is exactly zero;
by default that is where the law has fallen to 1 %, so the switch-off step is at most 1 %.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.dynamics import ThrustLaw, thrust_multiplier
from quad_dob_env.params import VehicleParams
from quad_dob_env.validation import unknown_name_error

# model name -> (coefficient c, exponent p)
GROUND_EFFECT_MODELS: dict[str, tuple[float, float]] = {
    "paper": (3.0 / 25.0, 1.0),
    "cheeseman-bennett": (1.0 / 16.0, 2.0),
}
_NEGLIGIBLE = 0.01  # the multiplier's excess over 1 at the default cutoff


class GroundEffect:
    """A ground-effect law for one vehicle above a floor at ``floor_height``.

    ``rotor_radius`` defaults to the vehicle's; ``min_height`` to half of it; the cutoff to
    the height where the multiplier is 1.01.
    """

    def __init__(self, model: str = "paper", rotor_radius: float | None = None,
                 min_height: float | None = None, cutoff_height: float | None = None) -> None:
        if model not in GROUND_EFFECT_MODELS:
            raise unknown_name_error("ground-effect model", model, sorted(GROUND_EFFECT_MODELS))
        self.model = model
        self.rotor_radius = rotor_radius
        self.min_height = min_height
        self.cutoff_height = cutoff_height

    def law(self, vehicle: VehicleParams, floor_height: float = 0.0) -> ThrustLaw:
        """The thrust multiplier law for ``vehicle`` over a floor at ``floor_height``."""
        coefficient, exponent = GROUND_EFFECT_MODELS[self.model]
        radius = vehicle.rotor_radius if self.rotor_radius is None else float(self.rotor_radius)
        if not (np.isfinite(radius) and radius > 0):
            raise ValueError(f"GroundEffect.rotor_radius must be > 0, got {self.rotor_radius!r}")
        singular = radius * coefficient ** (1.0 / exponent)  # where 1 - c (R/h)^p = 0
        min_height = radius / 2 if self.min_height is None else float(self.min_height)
        if not min_height > singular:
            raise ValueError(
                f"GroundEffect.min_height must exceed {singular:.4g} m, where the "
                f"{self.model!r} law is singular for rotor radius {radius} m; got {min_height}"
            )
        default_cutoff = radius * (coefficient / (1 - 1 / (1 + _NEGLIGIBLE))) ** (1 / exponent)
        cutoff = default_cutoff if self.cutoff_height is None else float(self.cutoff_height)
        if not cutoff > min_height:
            raise ValueError(
                f"GroundEffect.cutoff_height must exceed min_height {min_height} m, got {cutoff}"
            )
        return ThrustLaw(coefficient, exponent, radius, float(floor_height), min_height, cutoff)

    def multiplier(self, heights: ArrayLike, vehicle: VehicleParams,
                   floor_height: float = 0.0) -> NDArray[np.float64]:
        """``T_IGE / T`` at world heights ``heights``."""
        return thrust_multiplier(heights, self.law(vehicle, floor_height))

    def __repr__(self) -> str:
        return f"GroundEffect(model={self.model!r})"
