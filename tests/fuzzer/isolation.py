"""Running one configuration in an isolated child process.

Requests whose size comes from a huge option (a start spread of 10⁷ s, ``dt = 1e-4`` on the
training pool, a billion vehicles) run in a child process with an address-space limit, so a
request that is not refused cannot take the machine with it.

The child is this package run as a directory (``python tests/fuzzer --only K --json
--in-process``, by ``sys.executable``, its path absolute, so it runs from any directory);
it draws the configuration again from its seed and index and prints its ``Outcome`` as
JSON on its last line. A child that dies, or answers late, is a failure.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from .records import Failure, Outcome

PACKAGE = Path(__file__).resolve().parent  # what the child runs: tests/fuzzer
ISOLATED_MEMORY_LIMIT = 6 * 2**30  # address space of a child running a huge request
ISOLATED_TIMEOUT = 30.0  # [s] a huge request must be refused well within this
HANG_STOP = 900.0  # [s] a child given no timeout is stopped after this: it hangs


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ISOLATED_MEMORY_LIMIT, ISOLATED_MEMORY_LIMIT))


def run_isolated(config: dict[str, Any], timeout: float | None = ISOLATED_TIMEOUT) -> Outcome:
    """``run_config`` in a child process with an address-space limit and a timeout (None: no
    judgement by the clock, only a stop for a child that hangs)."""
    start = time.perf_counter()
    stop = HANG_STOP if timeout is None else timeout + 10
    command = [sys.executable, str(PACKAGE), "--seed",
               str(config["fuzz_seed"]), "--only", str(config["index"]), "--json",
               "--in-process"]
    try:
        done = subprocess.run(command, capture_output=True, text=True, preexec_fn=_limit_memory,
                              timeout=stop, check=False)
    except subprocess.TimeoutExpired:
        done = None
    wall = time.perf_counter() - start
    lines = done.stdout.strip().splitlines() if done is not None else []
    if done is not None and lines and lines[-1].startswith("{"):
        outcome = Outcome.from_json(json.loads(lines[-1]))
    else:
        outcome = Outcome(config["index"], status="failed", mode=config["mode"])
        why = (f"no answer within {stop:.0f} s" if done is None else
               f"the child exited {done.returncode}: "
               + (done.stderr.strip().splitlines() or [""])[-1][:300])
        outcome.failures.append(Failure(
            "memory_not_refused" if config["memory_hungry"] else "exception:child_died",
            config["index"], config["fuzz_seed"], why, phase="build", config=config))
    outcome.isolated = True
    if timeout is not None and outcome.wall > timeout and not outcome.failures:
        outcome.failures.append(Failure(
            "memory_not_refused" if config["memory_hungry"] else "timeout", config["index"],
            config["fuzz_seed"], f"took {outcome.wall:.0f} s", phase="build", config=config))
        outcome.status = "failed"
    outcome.wall = wall
    return outcome


def needs_isolation(config: dict[str, Any]) -> bool:
    """Whether the configuration asks for something huge: it runs in a child."""
    return config["memory_hungry"] or bool(config["huge"])
