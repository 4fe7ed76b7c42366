"""How much of its residual a ``ResidualCommand`` may fly: the disturbance gate and the fade
near the floor, both read from what the base reads (the observer's estimate, the measured
height), both a factor in [0, 1] on the clipped residual; and the guard on an acceleration
residual (``guard_correction``).

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
into, made it lose landings its base kept (docs/residual-rl.md, "The floor fade"). The fade
does not stop all of it. What the residual does higher up, early in the descent, can
leave the base's attitude mode swinging into the hover ("What loses the landings under
the margin").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.validation import as_finite, unknown_name_error

AUTHORITY_SIGNALS = ("force", "wind")
# how far an acceleration residual may tilt the base's desired force: tan 20°
HORIZONTAL_GUARD = float(np.tan(np.radians(20.0)))
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
