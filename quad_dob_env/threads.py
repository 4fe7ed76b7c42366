"""Run a compiled per-vehicle loop over the batch on every core.

Each kernel takes ``(start, stop, ...)`` and loops over vehicles ``start..stop-1``; it is
compiled once, serially, with ``nogil=True``. Large batches are cut into one contiguous
slice per core and the slices run on threads at the same time. Vehicles never share state,
so the result is bit for bit the one of a single serial call.

Why not numba's ``parallel=True``: its ``prange`` version of the environment step compiled
to code twice as slow per vehicle as the serial one, so two cores only matched one (and a
refactor of the loop body could make it fail to compile at all; its parfors take no tuples
of arrays, which the kernels are given). Why not a ``ThreadPoolExecutor``: its futures cost
~40 µs a hand-over; the daemon workers here take their slice from a ``SimpleQueue`` and
answer on another, a few microseconds each way. A forked child (Gymnasium's
``AsyncVectorEnv`` and SB3's ``SubprocVecEnv`` can fork) starts its own workers.

Only public ground: Python threads, a queue, and kernels compiled by numba's ``njit`` with
``nogil=True``. (Until 2026-12 workers also waited inside compiled code on libc semaphores
bound through llvmlite, ~25 µs a call faster at N = 256; that leaned on numba internals and
an assumed ``sizeof(sem_t)``, and is gone: docs/speed.md.)
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from functools import cache
from queue import SimpleQueue
from typing import Any

# Below this many vehicles a second thread costs more than it saves.
PARALLEL_MIN_BATCH = 256


@cache
def worker_count() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


class _Worker:
    """A daemon thread that runs the slices it is given, one at a time."""

    def __init__(self) -> None:
        self.jobs: SimpleQueue = SimpleQueue()
        self.done: SimpleQueue = SimpleQueue()
        threading.Thread(target=self._serve, daemon=True, name="quad-dob-slice").start()

    def _serve(self) -> None:
        while True:
            kernel, start, stop, args = self.jobs.get()
            try:
                kernel(start, stop, *args)
                self.done.put(time.perf_counter())
            except BaseException as error:  # handed back to the caller, which raises it
                self.done.put(error)


_workers: list[_Worker] = []
_lock = threading.Lock()  # one batch at a time uses the workers


def _forget_workers() -> None:
    """In a forked child: the parent's worker threads were not copied, so start afresh."""
    global _lock
    _workers.clear()
    _lock = threading.Lock()


if hasattr(os, "register_at_fork"):  # POSIX; elsewhere there is no fork
    os.register_at_fork(after_in_child=_forget_workers)
# Extra vehicles the calling thread takes, per kernel: a worker starts late (it is woken,
# then waits for the GIL to unpack its arguments while the caller unpacks its own), so equal
# slices leave the caller idle. Learnt from when each slice ends; the split never changes
# the results, only who computes which vehicles.
_lead: dict[Callable[..., None], float] = {}


def run_over_batch(kernel: Callable[..., None], n: int, *args: Any,
                   min_batch: int | None = None) -> None:
    """``kernel(start, stop, *args)`` over ``0..n-1``, split across the cores when ``n`` is at
    least ``min_batch`` (default ``PARALLEL_MIN_BATCH``; larger for cheaper kernels)."""
    min_batch = PARALLEL_MIN_BATCH if min_batch is None else min_batch
    if n < min_batch or worker_count() == 1 or not _lock.acquire(blocking=False):
        kernel(0, n, *args)  # small, one core, or another thread is using the workers
        return
    try:
        parts = min(worker_count(), n // (min_batch // 2))
        while len(_workers) < parts - 1:
            _workers.append(_Worker())
        lead = min(max(round(_lead.get(kernel, 0.0)), 0), n // (2 * parts))
        share = n - lead
        caller_stop = lead + share // parts
        start = caller_stop
        for k in range(1, parts):
            stop = lead + share * (k + 1) // parts
            _workers[k - 1].jobs.put((kernel, start, stop, args))
            start = stop
        started = time.perf_counter()
        kernel(0, caller_stop, *args)
        finished = time.perf_counter()
        answers = [_workers[k].done.get() for k in range(parts - 1)]
    finally:
        _lock.release()
    for answer in answers:
        if not isinstance(answer, float):
            raise answer
    last = max(answers)  # when the slowest worker finished
    # move a quarter of the caller's idle time's worth of vehicles to it (damped, so it
    # settles; bounded, so a worker slowed by the machine never gets nothing to do)
    per_vehicle = max(finished - started, 1e-9) / max(caller_stop, 1)
    _lead[kernel] = min(max(0.0, _lead.get(kernel, 0.0) + 0.25 * (last - finished) / per_vehicle),
                        n / (2 * parts))
