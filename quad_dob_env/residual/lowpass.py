"""The residual's low-pass (``residual_cutoff`` of ``quad_dob_env.residual``): what the
policy asks for, clipped to [-1, 1], passes a first-order low-pass of corner frequency
f_c before the authority gate and the floor fade scale it.

Why: under issue 29's margin (10 ms more latency, a motor 1.5 times slower) a residual
trained without it excites its base's 2-3 Hz attitude mode on the descent to a landing;
the base, alone again below the fade, has not damped it by the time it hovers at 8 cm and
touches the floor (docs/residual-rl.md, "What loses the landings under the margin"). A
penalty on the residual's rate of change (``residual_rate_weight``) only asks for
smoothness; the filter attenuates whatever the policy puts into the loop above f_c, by
1/√(1 + (f/f_c)²) at f (half at 2.45 Hz for f_c = 1.5 Hz). It is no hard limit: only the
clip to [-1, 1] is, and a policy that sees the filter's state may learn to push harder.

The filter's state is the policy's own past output, filtered: the observation shows it (4
entries after the look-ahead's), so the policy reads what it has already committed the
vehicle to and the env stays Markov. It is zero at each vehicle's start.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.validation import as_finite


class ResidualFilter:
    """First-order low-passes of the (N, 4) residual, one per vehicle and entry."""

    def __init__(self, n: int, dt: float, cutoff: float) -> None:
        self.cutoff = as_finite(cutoff, "residual_cutoff [Hz]", 0.0, strictly=True)
        # the exact zero-order-hold step of ẏ = 2π f_c (a - y) over one control step dt
        self.blend = float(-np.expm1(-2.0 * np.pi * self.cutoff * dt))
        self.state = np.zeros((n, 4))

    def restart(self, indices: NDArray[np.intp]) -> None:
        """Those vehicles' filters back to zero (an episode starts from the base alone)."""
        self.state[indices] = 0.0

    def step(self, residual: NDArray[np.float64]) -> NDArray[np.float64]:
        """Advance every filter by one control step with ``residual`` clipped to [-1, 1]
        held over it; the new state, copied."""
        self.state += self.blend * (np.clip(residual, -1.0, 1.0) - self.state)
        return self.state.copy()
