"""The floor fade (``floor_fade`` = (h₀, h₁) [m], in scenarios with a floor) gives
``clip((ĥ - h₀) / (h₁ - h₀), 0, 1)``, ĥ the measured height above the floor: below h₀ the
base flies alone. Touching the floor ends a flight. Under issue 29's margin (10 ms more
latency, a motor 1.5 times slower) the base's own hover at a landing's 8 cm, in wind and
ground effect, is marginal: it tilts by up to 18° and swings its rotor commands between 4
and 13 N. A residual acting there, or handing the base a state it would not have flown
into, made it lose landings its base kept (docs/research/landings-under-margin.md). The fade
does not stop all of it. What the residual does higher up, early in the descent, can
leave the base's attitude mode swinging into the hover ("What loses the landings under
the margin").

``FloorFade`` holds the heights; ``ResidualCommand`` asks it for the factor each step.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


class FloorFade:
    """The fade over the heights ``fade`` = (h₀, h₁) above a floor at ``floor_height``."""

    def __init__(self, fade: tuple[float, float], floor_height: float) -> None:
        self.low, self.high = fade
        self.floor_height = floor_height

    def factor(self, position: NDArray[np.float64]) -> NDArray[np.float64]:
        """The factor in [0, 1] at the measured positions (N, 3)."""
        return floor_factor(position[:, 2] - self.floor_height, (self.low, self.high))


def floor_factor(height: NDArray[np.float64], fade: tuple[float, float]) -> NDArray[np.float64]:
    """The floor fade's factor at the measured heights above the floor ``height`` (N,)."""
    low, high = fade
    return np.clip((height - low) / (high - low), 0.0, 1.0)
