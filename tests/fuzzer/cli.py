"""The command line, ``python tests/fuzzer`` (``main``): ``--configs N --seed S`` runs N
configurations and prints the report's summary; ``--only K`` reruns configuration K alone,
prints it, a Python reproduction and the full traceback of any failure (``--json
--in-process``: the outcome as JSON, what a child process of ``isolation`` answers).
Exit status 1 where anything failed.
"""

from __future__ import annotations

import argparse
import json

from .draw import draw_config, short_config
from .isolation import ISOLATED_TIMEOUT, needs_isolation, run_isolated
from .repro import repro_code
from .run import fuzz, run_config

DESCRIPTION = "A configuration fuzzer: random ids, scenarios, options, actions and vectorisation."


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=DESCRIPTION)
    parser.add_argument("--configs", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", type=int, default=None, help="run configuration K alone")
    parser.add_argument("--json", action="store_true", help="with --only: the outcome as JSON")
    parser.add_argument("--in-process", action="store_true",
                        help="with --only: do not isolate a huge request in a child")
    parser.add_argument("--time-limit", type=float, default=120.0,
                        help="seconds a configuration may take")
    args = parser.parse_args(argv)
    if args.only is not None:
        config = draw_config(args.seed, args.only)
        if args.json:
            outcome = run_config(config, ISOLATED_TIMEOUT if args.in_process else None)
            print(json.dumps(outcome.to_json(), default=str))
            return 0
        print(short_config(config))
        print("invalid options:", config["invalid"], "huge:", config["huge"],
              "memory-hungry:", config["memory_hungry"])
        print("--- reproduction\n" + repro_code(config) + "\n---")
        outcome = (run_isolated(config) if needs_isolation(config) and not args.in_process
                   else run_config(config, args.time_limit, keep_traceback=True))
        print(f"status: {outcome.status}; {outcome.step_calls} steps; reasons "
              f"{dict(outcome.reasons)}; {outcome.wall:.2f} s")
        if outcome.refusal:
            print("refusal:", outcome.refusal)
        for failure in outcome.failures:
            print(failure.describe())
            if failure.traceback:
                print(failure.traceback)
        return 1 if outcome.failures else 0
    report = fuzz(args.configs, args.seed, time_limit=args.time_limit, progress=True)
    print(report.summary())
    return 1 if report.failures else 0
