"""Counter-based normal numbers: vehicle i's n-th draw depends only on (key_i, n).

A key is drawn from the vehicle's own generator at reset; a compiled loop then makes the
per-step noise of every vehicle at once, and each vehicle's noise still follows from its
seed alone, whatever the batch (SplitMix64 hashing, Box–Muller).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _splitmix64(x):
    x = x + np.uint64(0x9E3779B97F4A7C15)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@njit(cache=True, inline="always")
def gaussian_pair(key, counter):
    """Two independent standard normals from a vehicle's key and a counter (Box–Muller)."""
    a = _splitmix64(key ^ _splitmix64(np.uint64(counter)))
    b = _splitmix64(a)
    u1 = (float(a >> np.uint64(11)) + 1.0) * 2.0**-53  # (0, 1]
    u2 = float(b >> np.uint64(11)) * 2.0**-53
    radius = math.sqrt(-2.0 * math.log(u1))
    return radius * math.cos(2.0 * math.pi * u2), radius * math.sin(2.0 * math.pi * u2)
