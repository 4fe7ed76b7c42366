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
minutes on a small machine. ``compiling_notice`` (``quad_dob_env.compile_notice``) wraps a
command's warm-up and says so, with the time to expect, once the warm-up has taken longer
than loading the cached kernels does.
"""

from __future__ import annotations

import shutil
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from typing import TextIO, TypeVar

# the notice lives with the simulator, whose first calls give it too (rl-zoo3, a script)
from quad_dob_env.compile_notice import (  # noqa: F401 (the commands' one import)
    COMPILE_MESSAGE,
    CompileNotice,
    compiling_notice,
    duration_text,
)

Item = TypeVar("Item")

# seconds without a printed line after which a log is told what is still running: the
# silence a person reading a log should have to sit through at most (the target: 10 s)
HEARTBEAT = 8.0


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
        if self.heartbeat <= 0:
            raise ValueError(f"Progress heartbeat must be > 0 seconds, got {self.heartbeat}")
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
            # more units than announced (a search that adds passes): the total grows
            self.total = max(self.total, self.count)
            if self.bar:
                self._draw()
            else:
                elapsed = self.clock() - self.began
                what = ": ".join(part for part in (self.unit, note) if part)
                self._line(f"{self.label} {self.count}/{self.total}"
                           + (f" {what}" if what else "") + f" ({duration_text(elapsed)} in)")
            self.unit = ""  # the heartbeat names no unit that is done

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
            left = f", ~{duration_text(elapsed / self.count * (self.total - self.count))} left"
        text = (f"{self.label} [{'#' * filled}{'.' * (width - filled)}] "
                f"{self.count}/{self.total} {self.unit} ({duration_text(elapsed)}{left})")
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
                               f"({duration_text(self.clock() - self.began)} in)")


def reported(items: Iterable[Item], label: str, *, name: Callable[[Item], str] = str,
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
