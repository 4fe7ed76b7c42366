"""Progress on long work: a bar on a terminal, one line per unit of work elsewhere.

Every command that runs longer than a few seconds (``quad-dob paper``, ``evaluate``,
``tune``, ``wind-tunnel``, ``train`` and the scripts in ``benchmarks/``) reports through
``Progress``, on standard error, so that what a command prints as its result (a table, or
JSON with ``--json``) stays clean on standard output.

- On a terminal, one bar redrawn in place: units done of the total, the unit running, the
  time spent and, once a unit is done, the time left at the pace so far.
- Elsewhere (a log, CI, a pipe), one line per unit done, and a line naming the unit still
  running whenever nothing was printed for ``HEARTBEAT`` seconds, so that no log is silent
  for longer than that.

A first run compiles the simulator's kernels (numba, cached on disk after), which takes
minutes on a small machine. ``compiling_notice`` wraps a warm-up and says so, with the time
to expect, once the warm-up has taken longer than loading the cached kernels does.
"""

from __future__ import annotations

import shutil
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import TextIO, TypeVar

Item = TypeVar("Item")

# seconds without a printed line after which a log is told what is still running: the
# silence a person reading a log should have to sit through at most (issue target: 10 s)
HEARTBEAT = 8.0
# seconds a warm-up may take before it is called a compilation: loading every cached
# kernel takes 0.6 s on the project's 2-core machine, compiling them 52 s
COMPILE_NOTICE_AFTER = 2.0
# what a first run's compilation costs, as measured on the project's 2-core machine with an
# empty numba cache: the vehicle's step 52 s, the composed loop 52 s more, a residual
# policy's 8 s (docs/troubleshooting.md, "The first run is slow")
COMPILE_MESSAGE = ("compiling the simulator's kernels (numba): a first run after installing "
                   "takes 1-2 min on 2 cores; later runs load them from the cache in about "
                   "a second")


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 100 else f"{seconds / 60:.1f} min"


class Progress:
    """Units of work done out of ``total``, reported as they finish.

    ``start(unit)`` names the unit now running; ``done(note)`` marks it finished (``note``:
    what it produced, in a few words). ``bar``: draw a bar in place (default: whether
    ``stream`` is a terminal). ``heartbeat``: seconds of silence before a log hears what
    is running (None: ``HEARTBEAT``). ``quiet``: report nothing (a library call, where only the
    command line reports). Use as a context manager, or call ``close()``: it ends the bar's
    line and stops the heartbeat."""

    def __init__(self, label: str, total: int, *, stream: TextIO | None = None,
                 bar: bool | None = None, heartbeat: float | None = None, quiet: bool = False,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if total < 0:
            raise ValueError(f"Progress total must be a count >= 0, got {total}")
        self.label, self.total = label, total
        self.quiet = quiet
        self.stream = sys.stderr if stream is None else stream
        self.bar = not quiet and (self._is_terminal(self.stream) if bar is None else bar)
        self.heartbeat = HEARTBEAT if heartbeat is None else heartbeat
        self.clock = clock
        self.count, self.unit = 0, ""
        self.began = self.last_line = clock()
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._ticker = threading.Thread(target=self._tick, daemon=True,
                                        name=f"progress:{label}")
        if not quiet:
            self._ticker.start()

    @staticmethod
    def _is_terminal(stream: TextIO) -> bool:
        isatty = getattr(stream, "isatty", None)
        return bool(isatty and isatty())

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

    def start(self, unit: str) -> None:
        """``unit`` is running now: the bar and the heartbeat name it."""
        with self._lock:
            self.unit = unit
            if self.bar:
                self._draw()

    def done(self, note: str = "") -> None:
        """The unit running is finished; ``note`` says what it produced."""
        with self._lock:
            self.count += 1
            if self.bar:
                self._draw()
            else:
                elapsed = self.clock() - self.began
                what = ": ".join(part for part in (self.unit, note) if part)
                self._line(f"{self.label} {self.count}/{self.total}"
                           + (f" {what}" if what else "") + f" ({_minutes(elapsed)} in)")

    def print(self, text: str, file: TextIO | None = None) -> None:
        """``text`` as a line of the command's own output (``file``, default standard
        output), above the bar on a terminal."""
        file = sys.stdout if file is None else file
        with self._lock:
            if self.bar:
                columns = shutil.get_terminal_size((100, 20)).columns
                self.stream.write("\r" + " " * (columns - 1) + "\r")
                self.stream.flush()
            file.write(text + "\n")
            file.flush()
            if self.bar:
                self._draw()
            elif file is self.stream:
                self.last_line = self.clock()

    def close(self) -> None:
        if self._closed.is_set():
            return
        self._closed.set()
        if self._ticker.is_alive():
            self._ticker.join(timeout=2.0)
        with self._lock:
            if self.bar:
                self.unit = "done"
                self._draw()
                self.stream.write("\n")
                self.stream.flush()

    def _line(self, text: str) -> None:
        if self.quiet:
            return
        self.stream.write(text + "\n")
        self.stream.flush()
        self.last_line = self.clock()

    def _draw(self) -> None:
        elapsed = self.clock() - self.began
        width = 20
        filled = width * self.count // self.total if self.total else width
        left = ""
        if 0 < self.count < self.total:
            left = f", ~{_minutes(elapsed / self.count * (self.total - self.count))} left"
        text = (f"{self.label} [{'#' * filled}{'.' * (width - filled)}] "
                f"{self.count}/{self.total} {self.unit} ({_minutes(elapsed)}{left})")
        columns = shutil.get_terminal_size((100, 20)).columns
        self.stream.write("\r" + text[:columns - 1].ljust(columns - 1))
        self.stream.flush()

    def _tick(self) -> None:
        # a bar shows time passing once a second; a log hears from a unit that runs long
        while not self._closed.wait(min(1.0, self.heartbeat / 2)):
            with self._lock:
                if self.bar:
                    self._draw()
                elif self.clock() - self.last_line >= self.heartbeat:
                    running = f"still on {self.unit}" if self.unit else "working"
                    self._line(f"{self.label} {self.count}/{self.total}: {running} "
                               f"({_minutes(self.clock() - self.began)} in)")


def steps(items: Iterable[Item], label: str, *, name: Callable[[Item], str] = str,
          stream: TextIO | None = None, total: int | None = None) -> Iterator[Item]:
    """``items``, reported through a ``Progress`` as each is taken and its work finishes
    (the work between two items is the earlier one's). ``name``: an item's words in the
    report."""
    items = list(items) if total is None else items
    with Progress(label, len(items) if total is None else total, stream=stream) as progress:
        for item in items:
            progress.start(name(item))
            yield item
            progress.done()


# set once COMPILE_MESSAGE is printed: a process says it once, however many warm-ups it has
COMPILE_MESSAGE_SAID = threading.Event()


class CompileNotice:
    """A timer on a warm-up that compiles the kernels on a first run: once ``start()`` is
    ``after`` seconds behind, longer than a load from the cache takes, it prints
    ``COMPILE_MESSAGE`` (once a process), and ``stop()`` then prints how long it took."""

    def __init__(self, stream: TextIO | None = None,
                 after: float = COMPILE_NOTICE_AFTER) -> None:
        self.stream = sys.stderr if stream is None else stream
        self.after = after
        self.fired = False
        self.began = 0.0
        self._timer: threading.Timer | None = None

    def start(self) -> None:
        self.began = time.monotonic()
        self._timer = threading.Timer(self.after, self._notice)
        self._timer.daemon = True
        self._timer.start()

    def _notice(self) -> None:
        self.fired = True
        if not COMPILE_MESSAGE_SAID.is_set():
            COMPILE_MESSAGE_SAID.set()
            self.stream.write(COMPILE_MESSAGE + "\n")
        else:
            self.stream.write("compiling more of the simulator's kernels\n")
        self.stream.flush()

    def stop(self) -> None:
        if self._timer is None:
            return
        self._timer.cancel()
        self._timer.join()  # a notice already being written ends before the summary
        self._timer = None
        if self.fired:
            self.stream.write(f"compiled in {_minutes(time.monotonic() - self.began)}\n")
            self.stream.flush()


@contextmanager
def compiling_notice(stream: TextIO | None = None,
                     after: float = COMPILE_NOTICE_AFTER) -> Iterator[None]:
    """``CompileNotice`` around the work inside."""
    notice = CompileNotice(stream, after)
    notice.start()
    try:
        yield
    finally:
        notice.stop()
