"""How much of its residual a ``ResidualCommand`` may fly: the disturbance gate and the fade
near the floor, both read from what the base reads (the observer's estimate, the measured
height), both a factor in [0, 1] on the clipped residual.

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

The floor fade (``floor_fade`` = (h₀, h₁) [m], in scenarios with a floor) gives
``clip((ĥ - h₀) / (h₁ - h₀), 0, 1)``, ĥ the measured height above the floor: below h₀ the
base flies alone. Touching the floor ends a flight. Under issue 29's margin (10 ms more
latency, a motor 1.5 times slower) the base's own hover at a landing's 8 cm, in wind and
ground effect, is marginal: it tilts by up to 18° and swings its rotor commands between 4
and 13 N. A residual acting there, or handing the base a state it would not have flown
into, made it lose landings its base kept (docs/residual-rl.md, "The floor fade").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.validation import as_finite, unknown_name_error

AUTHORITY_SIGNALS = ("force", "wind")
# [s] the "wind" gate's low-pass: long enough to average mocap's and gnss-imu's estimate
# noise below half a 0.04 gate in calm air (module docstring), short enough to follow the
# scenarios' 1-cosine gusts, which build over about a second
WIND_GATE_TIME_CONSTANT = 0.5


def check_signal(signal: str) -> str:
    if signal not in AUTHORITY_SIGNALS:
        raise unknown_name_error("authority_signal", signal, AUTHORITY_SIGNALS)
    return signal


def check_floor_fade(fade: Sequence[float] | None) -> tuple[float, float] | None:
    """``fade`` as (h₀, h₁) with 0 <= h₀ < h₁, or None (no fade)."""
    if fade is None:
        return None
    values = tuple(fade) if isinstance(fade, (tuple, list, np.ndarray)) else ()
    if len(values) != 2:
        raise ValueError(f"floor_fade must be two heights (h0, h1) in m, got {fade!r}")
    low, high = (as_finite(v, "floor_fade height", 0.0) for v in values)
    if not low < high:
        raise ValueError(f"floor_fade needs h0 < h1 (the residual fades in between), got "
                         f"{fade!r}")
    return low, high


def gate_factor(seen: NDArray[np.float64], gate: float) -> NDArray[np.float64]:
    """The gate's factor for the signal ``seen`` (N,) and the gate ``gate``."""
    return np.clip(2.0 * seen / gate - 1.0, 0.0, 1.0)


def floor_factor(height: NDArray[np.float64], fade: tuple[float, float]) -> NDArray[np.float64]:
    """The floor fade's factor at the measured heights above the floor ``height`` (N,)."""
    low, high = fade
    return np.clip((height - low) / (high - low), 0.0, 1.0)
