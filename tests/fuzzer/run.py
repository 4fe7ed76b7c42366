"""Running configurations: ``run_config`` builds, resets and flies one in this process under
a time limit (``SIGALRM``; ``FuzzTimeout``) and judges what it raised (a refusal, a refusal
by Gymnasium, or a failure, as the package's docstring says); ``fuzz`` runs ``count`` of
them, each huge request in a child process (``isolation``), into a ``FuzzReport``.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
import traceback
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym

from .draw import draw_config
from .flight import Flight, build
from .isolation import ISOLATED_TIMEOUT, needs_isolation, run_isolated
from .records import Failure, FuzzReport, Outcome

ROOT = Path(__file__).resolve().parents[2]  # the repository: where a failure's place is


class FuzzTimeout(BaseException):
    """A configuration ran past its time limit (not an Exception: nothing may swallow it)."""


def _in_repository(filename: str) -> bool:
    path = os.path.abspath(filename)
    return path.startswith(str(ROOT)) and "/.venv/" not in path and "/benchmarks/" not in path


def _where(exc: BaseException) -> str:
    frames = traceback.extract_tb(exc.__traceback__)
    inside = [f for f in frames if _in_repository(f.filename)]
    frame = inside[-1] if inside else (frames[-1] if frames else None)
    if frame is None:
        return ""
    return f"{os.path.relpath(frame.filename, ROOT)}:{frame.lineno} in {frame.name}"


def _raised_by_gymnasium(exc: BaseException) -> bool:
    frames = traceback.extract_tb(exc.__traceback__)
    return bool(frames) and "/gymnasium/" in frames[-1].filename


def _clear_error(exc: BaseException) -> bool:
    if isinstance(exc, gym.error.Error):
        return bool(str(exc).strip())
    return type(exc) is ValueError and bool(str(exc).strip())


def _last_line(exc: BaseException) -> str:
    return traceback.format_exception_only(type(exc), exc)[-1].strip()[:400]


@contextlib.contextmanager
def _time_limit(seconds: float | None):
    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expire(signum, frame):
        raise FuzzTimeout(f"configuration ran past {seconds:.0f} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_config(config: dict[str, Any], time_limit: float | None = 120.0,
               keep_traceback: bool = False, make: Any = None) -> Outcome:
    """Build (with ``make(config)``, default ``build``), reset and fly one configuration in
    this process; what happened."""
    make = make or build
    outcome = Outcome(config["index"], mode=config["mode"])
    start = time.perf_counter()
    flight = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with _time_limit(time_limit):
                env = make(config)
                outcome.built = True
                flight = Flight(config, env, outcome)
                flight.fly()
                flight.phase = "close"
                env.close()
                if config["replay"] and not outcome.failures:
                    flight.phase = "replay"
                    again = Flight(config, make(config), Outcome(config["index"]))
                    again.fly()
                    again.env.close()
                    if again.digest.digest() != flight.digest.digest():
                        flight.fail("nondeterministic", "the same configuration and seed, "
                                    "built and flown again, observed or rewarded otherwise")
        except (Exception, FuzzTimeout) as exc:
            phase = "build" if flight is None else flight.phase
            if phase in ("build", "reset") and _clear_error(exc):
                outcome.status, outcome.refusal = "refused", str(exc)
                outcome.built = False
                if phase == "reset":
                    outcome.notes.append("refused at the first reset, not when built")
            elif (phase == "build" and config["upstream_invalid"]
                  and _raised_by_gymnasium(exc)):
                outcome.status, outcome.refusal = "upstream", _last_line(exc)
            else:
                category = ("timeout" if isinstance(exc, FuzzTimeout)
                            else "memory_not_refused" if isinstance(exc, MemoryError)
                            else f"exception:{type(exc).__name__}")
                outcome.failures.append(Failure(
                    category, config["index"], config["fuzz_seed"], _last_line(exc),
                    _where(exc), phase, config,
                    "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
                    if keep_traceback else ""))
    for item in caught:
        if _in_repository(item.filename) or "gymnasium" in item.filename:
            where = os.path.relpath(item.filename, ROOT) if _in_repository(item.filename) \
                else "gymnasium"
            outcome.warnings.append(f"{item.category.__name__} at {where}:{item.lineno}: "
                                    f"{str(item.message)[:100]}")
    if outcome.failures and outcome.status == "built":
        outcome.status = "failed"
    if outcome.status == "built" and config["memory_hungry"]:
        outcome.failures.append(Failure(
            "memory_not_refused", config["index"], config["fuzz_seed"],
            "a request over the memory budget was built", phase="build", config=config))
        outcome.status = "failed"
    if outcome.status == "refused" and config["memory_hungry"] and \
            "memory" not in outcome.refusal:
        outcome.notes.append("a huge request was refused, without naming the memory budget")
    outcome.wall = time.perf_counter() - start
    return outcome


def fuzz(count: int, seed: int = 0, *, time_limit: float | None = 120.0,
         isolated_timeout: float | None = ISOLATED_TIMEOUT, isolate: bool = True,
         progress: bool = False) -> FuzzReport:
    """Try ``count`` configurations of run ``seed``; the figures and every failure.
    ``time_limit`` (a configuration) and ``isolated_timeout`` (a huge request's refusal):
    seconds, or None to judge nothing by the clock (the test suite's profile)."""
    report = FuzzReport(seed)
    start = time.perf_counter()
    for index in range(count):
        config = draw_config(seed, index)
        if isolate and needs_isolation(config):
            outcome = run_isolated(config, isolated_timeout)
        else:
            outcome = run_config(config, time_limit)
        report.add(outcome, config)
        if progress and (index + 1) % 50 == 0:
            print(f"  {index + 1}/{count} configurations, {len(report.failures)} failures, "
                  f"{time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    report.wall = time.perf_counter() - start
    return report
