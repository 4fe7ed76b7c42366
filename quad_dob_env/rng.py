"""Counter-based normal numbers: vehicle i's n-th draw depends only on (key_i, n).

A key is drawn from the vehicle's own generator at reset; a compiled loop then makes the
per-step noise of every vehicle at once, and each vehicle's noise still follows from its
seed alone, whatever the batch (SplitMix64 hashing, Box–Muller).

``named_stream``: a mechanism's own generator for an episode, fixed by its name, so that
switching any other mechanism on or off never moves its draws.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from numba import njit

# above every index ``Generator.spawn`` hands out in practice, so a named stream never is a
# spawned child
NAMED_STREAM_OFFSET = 2**32


def named_stream(parent: np.random.Generator, name: str) -> np.random.Generator:
    """The generator of mechanism ``name`` under ``parent`` (an episode's child of a
    vehicle's generator): the child whose spawn key extends ``parent``'s by a number fixed
    by the name (its CRC-32 above ``NAMED_STREAM_OFFSET``), not by how many children were
    spawned before it. Making it draws nothing from ``parent``."""
    seed = parent.bit_generator.seed_seq
    key = NAMED_STREAM_OFFSET + zlib.crc32(name.encode())
    child = np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, key),
                                   pool_size=seed.pool_size)
    return np.random.Generator(type(parent.bit_generator)(child))


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
