"""One named entry of an observation vector: the record ``envs.observation`` and
``residual.observation`` tabulate, and ``UNBOUNDED``, the range of an entry nothing bounds.
Imports nothing of the package."""

from __future__ import annotations

import math
from dataclasses import dataclass

# the range of an entry whose values nothing bounds by construction (still clamped to
# float32's range when observed)
UNBOUNDED = (-math.inf, math.inf)


@dataclass(frozen=True)
class ObservationEntry:
    """``size`` consecutive observation columns that mean one thing. ``bounds`` is the
    range the entry's values take by construction ((-inf, inf) where nothing bounds them;
    every observation is still clamped to float32's range, so it stays finite).
    ``start`` is its first column once placed in a table (``envs.observation``)."""

    name: str
    description: str
    unit: str
    size: int
    bounds: tuple[float, float]
    start: int = -1

    @property
    def columns(self) -> slice:
        """Its columns in the observation vector."""
        if self.start < 0:
            raise ValueError(f"observation entry {self.name!r} has no columns until placed "
                             "in a table (quad_dob_env.envs.observation.observation_table)")
        return slice(self.start, self.start + self.size)
