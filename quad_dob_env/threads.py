"""Run a compiled per-vehicle loop over the batch on every core.

Each kernel takes ``(start, stop, ...)`` and loops over vehicles ``start..stop-1``; it is
compiled once, serially, with ``nogil=True``. Large batches are cut into one contiguous
slice per core and the slices run on threads at the same time. Vehicles never share state,
so the result is bit for bit the one of a single serial call.

Why not numba's ``parallel=True``: its ``prange`` version of the environment step compiled
to code twice as slow per vehicle as the serial one, so two cores only matched one (and a
refactor of the loop body could make it fail to compile at all).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import cache
from typing import Any

# Below this many vehicles a second thread costs more (~30 µs to hand over) than it saves.
PARALLEL_MIN_BATCH = 256

_pool: ThreadPoolExecutor | None = None


@cache
def worker_count() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def run_over_batch(kernel: Callable[..., None], n: int, *args: Any,
                   min_batch: int | None = None) -> None:
    """``kernel(start, stop, *args)`` over ``0..n-1``, split across the cores when ``n`` is at
    least ``min_batch`` (default ``PARALLEL_MIN_BATCH``; larger for cheaper kernels)."""
    global _pool
    min_batch = PARALLEL_MIN_BATCH if min_batch is None else min_batch
    if n < min_batch or worker_count() == 1:
        kernel(0, n, *args)
        return
    workers = min(worker_count(), n // (min_batch // 2))
    if _pool is None or _pool._max_workers < workers - 1:
        _pool = ThreadPoolExecutor(max_workers=workers - 1, thread_name_prefix="quad-dob")
    bounds = [n * k // workers for k in range(workers + 1)]
    others = [_pool.submit(kernel, bounds[k], bounds[k + 1], *args) for k in range(1, workers)]
    kernel(bounds[0], bounds[1], *args)
    for future in others:
        future.result()
