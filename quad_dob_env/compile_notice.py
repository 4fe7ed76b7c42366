"""The notice a first run prints while numba compiles the simulator's kernels.

The kernels are compiled on their first call and cached on disk (beside the modules, or
under ``NUMBA_CACHE_DIR``). A first run after installing compiles them, which takes one to
two minutes on a small machine, and a process that compiles would otherwise be silent for
that long, whoever drives it (``quad-dob``, rl-zoo3, a user's script). ``announces_compiling``
marks the simulator's entry points: their first calls in a process run under a
``CompileNotice``, which says, once the call has taken longer than a load from the cache
takes, that the kernels are compiling and what to expect, and when done how long it took.
"""

from __future__ import annotations

import functools
import multiprocessing
import sys
import threading
import time
import types
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO

# seconds a first call may take before it is called a compilation: loading every cached
# kernel takes 0.6 s on the project's 2-core machine, compiling them 52 s
COMPILE_NOTICE_AFTER = 2.0
# what a first run's compilation costs, as measured on the project's 2-core machine with an
# empty numba cache: the vehicle's step 52 s, the composed loop 52 s more, a residual
# policy's 8 s (docs/troubleshooting.md, "The first run is slow: the kernels compile")
COMPILE_MESSAGE = ("compiling the simulator's kernels (numba): a first run after installing "
                   "takes 1-2 min on 2 cores; later runs load them from the cache in about "
                   "a second")
# seconds between two "still compiling" lines: no log is silent for longer (the issue's
# target is 10 s)
COMPILE_HEARTBEAT = 8.0
# set once COMPILE_MESSAGE is printed: a process says it once, however many notices it has
COMPILE_MESSAGE_SAID = threading.Event()
# a notice is timing a call: calls inside it (a vector env's step runs the core's) add none
_TIMING = threading.local()


def duration_text(seconds: float) -> str:
    """``12 s`` or, from 100 s, ``2.5 min``."""
    return f"{seconds:.0f} s" if seconds < 100 else f"{seconds / 60:.1f} min"


class CompileNotice:
    """A timer on work that compiles the kernels on a first run: once ``start()`` is
    ``after`` seconds behind (None: ``COMPILE_NOTICE_AFTER``), it prints
    ``COMPILE_MESSAGE`` (once a process; a later notice says that more kernels compile)
    and then a line every ``COMPILE_HEARTBEAT`` seconds, and ``stop()`` prints how long it
    took."""

    def __init__(self, stream: TextIO | None = None, after: float | None = None) -> None:
        self.stream = stream
        self.after = COMPILE_NOTICE_AFTER if after is None else after
        self.fired = False
        self.began = 0.0
        self._timer: threading.Thread | None = None
        self._done = threading.Event()

    def _write(self, text: str) -> None:
        stream = sys.stderr if self.stream is None else self.stream
        stream.write(text + "\n")
        stream.flush()

    def start(self) -> None:
        self.began = time.monotonic()
        self._done = threading.Event()
        self._timer = threading.Thread(target=self._watch, daemon=True,
                                       name="compile-notice")
        self._timer.start()

    def _watch(self) -> None:
        # the notice once the work is slow, then a line every COMPILE_HEARTBEAT seconds:
        # a log hears that the compiler still runs
        if self._done.wait(self.after):
            return
        self.fired = True
        if not COMPILE_MESSAGE_SAID.is_set():
            COMPILE_MESSAGE_SAID.set()
            self._write(COMPILE_MESSAGE)
        else:
            self._write("compiling more of the simulator's kernels")
        if multiprocessing.parent_process() is not None:
            return  # a worker (SubprocVecEnv, a pool): its parent speaks for the rest
        while not self._done.wait(COMPILE_HEARTBEAT):
            self._write(f"still compiling ({duration_text(time.monotonic() - self.began)})")

    def stop(self) -> None:
        if self._timer is None:
            return
        self._done.set()
        self._timer.join()  # a line already being written ends before the summary
        self._timer = None
        if self.fired:
            self._write(f"compiled in {duration_text(time.monotonic() - self.began)}")


@contextmanager
def compiling_notice(stream: TextIO | None = None,
                     after: float | None = None) -> Iterator[None]:
    """``CompileNotice`` around the work inside; inside another, none of its own. Work
    that raises ends the notice without a "compiled in"."""
    if getattr(_TIMING, "active", False):
        yield
        return
    notice = CompileNotice(stream, after)
    try:
        _TIMING.active = True
        notice.start()
        yield
    except BaseException:
        notice.fired = False  # nothing was compiled to the end: no summary
        raise
    finally:
        notice.stop()
        _TIMING.active = False


class announces_compiling:  # noqa: N801 (used as a decorator, named as one)
    """Mark an entry point of the simulator (a method): its first call in this process runs
    under a ``compiling_notice``, and then the class's attribute becomes the plain method
    again, so the per-step path pays nothing for the notice after the first call."""

    def __init__(self, method: Callable[..., Any]) -> None:
        self.method = method
        self.owner: type | None = None
        self.name = method.__name__
        functools.update_wrapper(self, method)

    def __set_name__(self, owner: type, name: str) -> None:
        self.owner, self.name = owner, name

    def __get__(self, instance: Any, owner: type | None = None) -> Any:
        if instance is None:  # the class's own attribute: signatures, pickling by name
            return self.method

        @functools.wraps(self.method)
        def first_call(bound: Any, *args: Any, **kwargs: Any) -> Any:
            with compiling_notice():
                result = self.method(bound, *args, **kwargs)
            if self.owner is not None:  # the one class that declared it, not a subclass
                setattr(self.owner, self.name, self.method)
            return result

        return types.MethodType(first_call, instance)  # bound, as the plain method is
