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

Two ways to use them: ``run_over_batch`` for any kernel (the workers unpack its arguments
at every call), and ``ParkedWorkers`` for a kernel called every step on the same arrays:
its workers wait inside compiled code with the arguments unpacked once, woken by a POSIX
semaphore, which saves ~25 µs a call (the residual pass at N = 256: ~150 µs a step instead
of ~175).
"""

from __future__ import annotations

import ctypes
import os
import sys
import threading
import time
import weakref
from collections.abc import Callable
from functools import cache
from queue import SimpleQueue
from typing import Any

import llvmlite.binding as llvm
import numpy as np
from llvmlite import ir
from numba import njit, typeof, types
from numba.core import cgutils
from numba.extending import intrinsic

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


_fork_generation = 0  # counts forks into this process: parked workers of an older one are gone


def _forget_workers() -> None:
    """In a forked child: the parent's worker threads were not copied, so start afresh."""
    global _lock, _fork_generation
    _workers.clear()
    _lock = threading.Lock()
    _fork_generation += 1


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


# --- parked workers: threads waiting inside compiled code ----------------------------------
# ``run_over_batch`` pays, every call, a worker's wake-up and the unpacking of the kernel's
# arguments by both threads, one after the other under the GIL: ~45 µs for the residual
# pass's ~120 arguments, as much as its first 45 vehicles. A kernel called every step on the
# same arrays can instead have one worker per extra core wait inside compiled code on a
# POSIX semaphore with its arguments unpacked once; the caller posts the other slices, runs
# its own and sleeps until the rest are done (a call costs ~20 µs more than half the serial
# time). The semaphore functions are libc's, bound by name for the compiled code so that it
# stays cacheable; where they are missing (not Linux), ``ParkedWorkers.run`` declines and
# the caller uses ``run_over_batch``.

_SEMAPHORE_BYTES = 32  # sizeof(sem_t) on Linux, x86-64 and aarch64 alike
_LIBC_SYMBOLS = ("sem_init", "sem_wait", "sem_trywait", "sem_post")


def _bind_libc() -> Any:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        for name in _LIBC_SYMBOLS:
            llvm.add_symbol(f"quad_dob_{name}",
                            ctypes.cast(getattr(libc, name), ctypes.c_void_p).value)
    except (OSError, AttributeError):
        return None
    libc.sem_init.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_uint]
    return libc


_libc = _bind_libc()


def _libc_call(builder: Any, name: str, argument_types: list, arguments: list) -> Any:
    function_type = ir.FunctionType(ir.IntType(32), argument_types)
    function = cgutils.get_or_insert_function(builder.module, function_type, f"quad_dob_{name}")
    return builder.call(function, arguments)


def _semaphore_codegen(name: str) -> Callable[..., Any]:
    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        pointer = ir.IntType(8).as_pointer()
        return _libc_call(builder, name, [pointer], [builder.inttoptr(args[0], pointer)])
    return codegen


@intrinsic
def _sem_post(typingctx: Any, address: Any) -> Any:
    return types.int32(types.intp), _semaphore_codegen("sem_post")


@intrinsic
def _sem_wait(typingctx: Any, address: Any) -> Any:
    """0, or -1 when a signal interrupted the wait (EINTR)."""
    return types.int32(types.intp), _semaphore_codegen("sem_wait")


@intrinsic
def _sem_trywait(typingctx: Any, address: Any) -> Any:
    """0 when the semaphore was posted (and takes it), else -1 at once."""
    return types.int32(types.intp), _semaphore_codegen("sem_trywait")


@njit(cache=True, nogil=True)
def _wait(address):
    while _sem_wait(address) != 0:  # a signal interrupted it: wait again
        pass


# control[k]: worker k's slice (start, stop), a request to return, and whether its kernel
# raised (the compiled code can only report it)
_START, _STOP, _QUIT, _FAILED = range(4)


@njit(cache=True, nogil=True)
def await_slice(control, semaphores, k):
    """In worker k's loop: sleep until it is given a slice; False when it should return."""
    _wait(semaphores.ctypes.data + (2 * k) * _SEMAPHORE_BYTES)
    return control[k, _QUIT] == 0


@njit(cache=True, nogil=True)
def slice_done(control, semaphores, k, failed):
    """In worker k's loop: report its slice done (``failed``: the kernel raised)."""
    control[k, _FAILED] = failed
    _sem_post(semaphores.ctypes.data + (2 * k + 1) * _SEMAPHORE_BYTES)


@njit(cache=True, nogil=True)
def hand_out(control, semaphores, bounds):
    """In the caller's launch: give worker k (k >= 1) the slice ``bounds[k]..bounds[k+1]``;
    the caller runs slice 0 itself."""
    for k in range(1, len(bounds) - 1):
        control[k, _START], control[k, _STOP] = bounds[k], bounds[k + 1]
        _sem_post(semaphores.ctypes.data + (2 * k) * _SEMAPHORE_BYTES)


@njit(cache=True, nogil=True)
def collect(control, semaphores, failed):
    """In the caller's launch, after its own slice (``failed``: it raised): sleep until
    every worker is done. Returns 1 if a worker or the caller failed, plus 2 if the caller
    had to wait (it should take more vehicles)."""
    waited = False
    for k in range(1, len(control)):
        done = semaphores.ctypes.data + (2 * k + 1) * _SEMAPHORE_BYTES
        if _sem_trywait(done) != 0:
            waited = True
            _wait(done)
        failed = failed or control[k, _FAILED] != 0
    return int(failed) + 2 * int(waited)


def _stop_workers(control: np.ndarray, semaphores: np.ndarray, pid: int) -> None:
    """Ask the parked workers to return (in a forked child there are none to ask)."""
    if pid != os.getpid():
        return
    control[:, _QUIT] = 1
    for k in range(1, len(control)):
        _libc.sem_post(ctypes.c_void_p(semaphores.ctypes.data + 2 * k * _SEMAPHORE_BYTES))


class ParkedWorkers:
    """``kernel(start, stop, *args)`` over ``0..n-1`` for a kernel called every step on the
    same arrays: worker k (one per core but the caller's) runs
    ``serve(args, control, semaphores, k)``, a compiled loop of ``await_slice``, the kernel
    on ``control[k, 0:2]`` and ``slice_done``; the caller runs
    ``launch(args, control, semaphores, bounds)``: ``hand_out``, the kernel on slice 0,
    ``collect``. Each kernel has its own small pair (``envs.kernels.step_worker``/
    ``step_launch``, ``quad_dob_baselines.fused``'s), because numba cannot cache a function that
    takes the kernel as an argument (8 s of compilation in every process). The owner of
    ``args`` must make new ``ParkedWorkers`` when one of its arrays is replaced; the workers
    return when this object is collected or ``close``d. A forked child starts its own."""

    def __init__(self, kernel: Callable[..., None], serve: Callable[..., None],
                 launch: Callable[..., None], n: int, args: tuple) -> None:
        self.kernel, self.serve, self.launch, self.n, self.args = kernel, serve, launch, n, args
        self.parts = max(1, min(worker_count(), n // (PARALLEL_MIN_BATCH // 2)))
        self._bounds = np.array([n * k // self.parts for k in range(self.parts + 1)])
        self._equal = int(self._bounds[1])  # the caller's share without a lead
        self._lead, self._most_lead = 0, n // (2 * self.parts)
        self._generation = -1
        self._finalizer: Any = None
        self.threads: list[threading.Thread] = []

    def run(self) -> None:
        """The kernel over all N vehicles: on the parked workers, or serially when the batch
        is too small, there is one core or another thread is using the workers (through
        ``run_over_batch`` where libc's semaphores are missing)."""
        if _libc is None:
            run_over_batch(self.kernel, self.n, *self.args)
            return
        if self.parts < 2 or not _lock.acquire(blocking=False):
            self.kernel(0, self.n, *self.args)
            return
        try:
            if self._generation != _fork_generation:  # first call, or a forked child
                self._start()
            outcome = self._launch(self.args, self._control, self._semaphores, self._bounds)
        finally:
            _lock.release()
        if outcome & 1:
            raise RuntimeError(f"{getattr(self.launch, '__name__', self.launch)} failed; hold "
                               "quad_dob_env.threads._lock to run it serially and see why")
        # one vehicle more for the caller when it waited for a worker, one less when not:
        # the split settles where both finish together (the worker starts a wake-up late)
        lead = self._lead + 1 if outcome & 2 else self._lead - 1
        if 0 <= lead <= self._most_lead:
            self._lead = lead
            self._bounds[1] = self._equal + lead

    def close(self) -> None:
        if self._finalizer is not None:
            self._finalizer()

    def _entry_point(self) -> Callable[..., int]:
        """``launch``'s compiled code for these very arguments, called without numba's
        dispatch: it would type ~120 arguments every step (~5 µs) to find, each time, the
        version found here, as the objects never change."""
        call = (self.args, self._control, self._semaphores, self._bounds)
        overloads = getattr(self.launch, "overloads", None)
        if overloads is None:  # not a numba function
            return self.launch
        signature = tuple(typeof(value) for value in call)
        if signature not in overloads:
            self.launch.compile(signature)
        return overloads[signature].entry_point

    def _start(self) -> None:
        self._control = np.zeros((self.parts, 4), dtype=np.int64)
        self._semaphores = np.zeros(2 * self.parts * _SEMAPHORE_BYTES, dtype=np.uint8)
        for j in range(2 * self.parts):
            _libc.sem_init(ctypes.c_void_p(self._semaphores.ctypes.data + j * _SEMAPHORE_BYTES),
                           0, 0)
        self.threads = [threading.Thread(target=self.serve, daemon=True, name="quad-dob-parked",
                                         args=(self.args, self._control, self._semaphores, k))
                        for k in range(1, self.parts)]
        for thread in self.threads:
            thread.start()
        self._launch = self._entry_point()
        self._generation = _fork_generation
        self._finalizer = weakref.finalize(self, _stop_workers, self._control,
                                           self._semaphores, os.getpid())
