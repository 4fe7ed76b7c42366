"""Speed of the working tree beside named commits, interleaved in one run.

Run by hand, e.g. ``python benchmarks/side_by_side.py --commits b48d628,5a52e7e``.

How each version is installed:
- Each named commit is checked out in a git worktree under ``--workdir`` and installed there
  on its own: a small virtual environment per commit, whose ``site-packages`` reaches this
  interpreter's packages through a ``.pth`` line (numpy, numba, gymnasium, torch: one build
  for every version), and ``pip install --no-deps -e`` of the worktree. The commit's own
  ``pyproject.toml`` says under which names its folders install, so a commit that installs
  its packages differently from today still imports as it did. The installed project of
  this interpreter is never touched.
- The working tree runs on this interpreter, which must have it installed (``make`` does).

How it measures:
- Every repeat of every case is a fresh process on a warm numba cache: one untimed process
  per version compiles first.
- The versions run in the order A B C A B C ..., so the machine's drift falls on every
  version alike. A sequential run would not compare.
- It prints each version's median rate and the ratio of the first version (the working tree,
  or ``--against``) to each: the median, min and max of the per-repeat ratios, and whether
  every repeat falls on one side of 1.

The cases (``--cases``):
- ``v1``, ``v1-4096``: ``TrackResidual-v1`` on ``paper-none``, N = 1024 and 4096, a zero
  residual (the base, ``geometric-ndob:tuned``, in the loop).
- ``v3``: ``TrackResidual-v3`` on ``dryden-helix-gusts``, N = 1024, a zero residual;
  ``v1-windy``: ``TrackResidual-v1`` on the same scenario (v3's loop against v1's).
- ``v4``: ``TrackResidual-v4`` on ``dryden-helix-gusts``, N = 1024, a zero residual.
- ``single-v1``, ``single-v3``: ``gym.make('QuadDOB/Track-v1')`` on ``paper-none`` and
  ``gym.make('QuadDOB/TrackResidual-v3')`` on its own scenario, random actions, resets
  counted.

``--pair A,B`` sets two cases side by side instead, on the working tree alone: A B A B ...,
each repeat a fresh process, and the ratio of A's rate to B's (e.g. ``--pair v4,v3``,
Benchmark v4's loop against v3's on one scenario).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import sysconfig
from collections.abc import Callable
from pathlib import Path

from quad_dob_training.progress import Progress

ROOT = Path(__file__).resolve().parent.parent
# case name -> (kind, env id, scenario, vehicles)
CASES = {
    "v1": ("vector", "QuadDOB/TrackResidual-v1", "paper-none", 1024),
    "v1-4096": ("vector", "QuadDOB/TrackResidual-v1", "paper-none", 4096),
    "v3": ("vector", "QuadDOB/TrackResidual-v3", "dryden-helix-gusts", 1024),
    "v4": ("vector", "QuadDOB/TrackResidual-v4", "dryden-helix-gusts", 1024),
    "v1-windy": ("vector", "QuadDOB/TrackResidual-v1", "dryden-helix-gusts", 1024),
    "single-v1": ("single", "QuadDOB/Track-v1", "paper-none", 1),
    "single-v3": ("single", "QuadDOB/TrackResidual-v3", "", 1),  # "": the id's own
}

# One measurement, in a fresh process: steps per second after a few that compile and warm
# up. A vector case counts env-steps (N per step); a single env counts its steps, resets
# included, with uniformly random actions.
MEASURE = """
import json, sys, time
import gymnasium as gym
import numpy as np
import quad_dob_env
kind, env_id, scenario = sys.argv[1], sys.argv[2], sys.argv[3]
n, steps = int(sys.argv[4]), int(sys.argv[5])
if kind == "vector":
    env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                       scenario=scenario)
    env.reset(seed=0)
    actions = np.zeros((n, 4))
    for _ in range(3):
        env.step(actions)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(actions)
    rate = n * steps / (time.perf_counter() - start)
else:
    env = gym.make(env_id, **({"scenario": scenario} if scenario else {}))
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (steps + 200, 4)).astype(np.float32)
    for action in actions[:200]:
        env.step(action)
    env.reset(seed=0)
    start = time.perf_counter()
    for action in actions[200:]:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    rate = steps / (time.perf_counter() - start)
print(json.dumps({"rate": rate, "module": quad_dob_env.__file__}))
"""


def run(command: list[str], **kwargs) -> subprocess.CompletedProcess:
    """``command``, its output kept; a failure raises with the tail of what it printed."""
    result = subprocess.run(command, capture_output=True, text=True, **kwargs)
    if result.returncode:
        raise RuntimeError(f"{' '.join(command)} failed:\n{result.stderr[-3000:]}")
    return result


def _say(text: str) -> None:
    print(text, flush=True)


def installed(commit: str, workdir: Path, say: Callable[[str], None] = _say) -> Path:
    """The python of ``commit``'s own environment: a worktree of it and an editable install
    of that worktree (both made once, then reused). ``say``: how it prints what it does."""
    tree, venv = workdir / f"tree-{commit}", workdir / f"venv-{commit}"
    python = venv / "bin" / "python"
    if not tree.exists():
        say(f"checking out {commit} into {tree} ...")
        run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), commit])
    if not (venv / ".installed").exists():
        say(f"installing {commit} into {venv} ...")
        # no pip of its own: this interpreter's pip and setuptools come through the .pth
        run([sys.executable, "-m", "venv", "--clear", "--without-pip", str(venv)])
        site = Path(run([str(python), "-c", "import sysconfig; "
                         "print(sysconfig.get_paths()['purelib'])"]).stdout.strip())
        # this interpreter's packages (not its .pth files, so not its editable project)
        (site / "shared-dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
        run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation",
             "-e", str(tree)])
        (venv / ".installed").touch()
    return python


def measure(python: Path, case: str, steps: int, cwd: Path) -> dict:
    kind, env_id, scenario, vehicles = CASES[case]
    result = run([str(python), "-c", MEASURE, kind, env_id, scenario, str(vehicles),
                  str(steps)], cwd=cwd, env={k: v for k, v in os.environ.items()
                                             if k != "PYTHONPATH"})
    return json.loads(result.stdout.strip().splitlines()[-1])


def compare_cases(pair: list[str], repeats: int, steps: int, workdir: Path) -> None:
    """Two cases interleaved on the working tree: each one's median rate, and A / B."""
    workdir.mkdir(parents=True, exist_ok=True)
    python = Path(sys.executable)
    print(f"side_by_side: {' and '.join(pair)} on the working tree, {repeats} interleaved "
          "repeats, each a fresh process", file=sys.stderr, flush=True)
    rates: dict[str, list[float]] = {case: [] for case in pair}
    with Progress("side_by_side", len(pair) * (1 + repeats)) as progress:
        for case in pair:
            progress.start(f"compiling {case}")
            measure(python, case, 3, workdir)  # compiles into the cache
            progress.done()
        for repeat in range(repeats):
            for case in pair:
                progress.start(f"repeat {repeat + 1}/{repeats}, {case}")
                kind = CASES[case][0]
                rates[case].append(measure(python, case,
                                           steps * (100 if kind == "single" else 1),
                                           workdir)["rate"])
                progress.done(f"{rates[case][-1] / 1e3:,.1f}k steps/s")
            progress.print(f"repeat {repeat + 1}/{repeats}: " + ", ".join(
                f"{case} {values[-1] / 1e3:,.1f}k" for case, values in rates.items()))
    first, second = pair
    ratios = [a / b for a, b in zip(rates[first], rates[second], strict=True)]
    print("\n| case | steps/s (median) |\n|---|---|")
    for case, values in rates.items():
        print(f"| {case}: {CASES[case][1]} on {CASES[case][2]}, N = {CASES[case][3]} | "
              f"{statistics.median(values):,.0f} |")
    print(f"\n{first} / {second}: median {statistics.median(ratios):.3f} "
          f"[{min(ratios):.3f}, {max(ratios):.3f}] over {repeats} interleaved repeats")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--commits", default="5a52e7e",
                        help="comma-separated commits to set beside the working tree")
    parser.add_argument("--against", default=None,
                        help="a commit to put first instead of the working tree (the "
                             "ratios divide its rate by each other's), e.g. a commit's "
                             "parent in a bisection")
    parser.add_argument("--no-working-tree", action="store_true",
                        help="measure the named commits only")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--steps", type=int, default=200,
                        help="vector steps per repeat (a single env takes 100 times this)")
    parser.add_argument("--cases", default="v1,v3", help=f"comma-separated, of: "
                                                         f"{', '.join(CASES)}")
    parser.add_argument("--workdir", default="/tmp/quad-dob-side-by-side")
    parser.add_argument("--pair", default=None,
                        help="two cases, A,B, interleaved on the working tree (module doc)")
    args = parser.parse_args()
    if args.pair:
        pair = [case.strip() for case in args.pair.split(",")]
        if len(pair) != 2 or any(case not in CASES for case in pair):
            parser.error(f"--pair takes two of the cases {', '.join(CASES)}, got {args.pair!r}")
        compare_cases(pair, args.repeats, args.steps, Path(args.workdir))
        return
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    cases = [case.strip() for case in args.cases.split(",")]
    unknown = [case for case in cases if case not in CASES]
    if unknown:
        parser.error(f"unknown case(s) {unknown}; the cases are {', '.join(CASES)}")
    # each commit to install, once, in the order the versions are set side by side
    commits = list(dict.fromkeys([*([args.against] if args.against else []),
                                  *filter(None, args.commits.split(","))]))
    print(f"side_by_side: {len(cases)} cases x {len(commits) + (not args.no_working_tree)} "
          f"versions x {args.repeats} interleaved repeats, each a fresh process"
          + (f"; installing {len(commits)} commits first" if commits else ""),
          file=sys.stderr, flush=True)
    made: dict[str, Path] = {}
    with Progress("side_by_side install", len(commits)) as progress:
        for commit in commits:
            progress.start(commit)
            made[commit] = installed(commit, workdir, progress.print)
            progress.done()
    versions: dict[str, Path] = {}
    if args.against:
        versions[args.against] = made[args.against]
    if not args.no_working_tree:
        versions["working tree"] = Path(sys.executable)
    for commit in filter(None, args.commits.split(",")):
        if commit not in versions:
            versions[commit] = made[commit]
    for case in cases:
        kind, env_id, scenario, vehicles = CASES[case]
        steps = args.steps * (100 if kind == "single" else 1)
        print(f"\n## {case}: {env_id} on {scenario}, N = {vehicles}, {steps} steps, "
              f"{args.repeats} interleaved repeats", flush=True)
        flown = {}  # the versions that have this case (an old commit may lack the id)
        rates: dict[str, list[float]] = {}
        with Progress(f"side_by_side {case}",
                      len(versions) * (1 + args.repeats)) as progress:
            for name, python in versions.items():  # compiles into each version's cache
                progress.start(f"compiling {name}")
                try:
                    module = measure(python, case, 3, workdir)["module"]
                except RuntimeError as error:
                    progress.total -= args.repeats  # none of its repeats will run
                    progress.done("cannot fly it")
                    progress.print(f"{name} cannot fly {case}: "
                                   f"{str(error).splitlines()[-1]}")
                    continue
                progress.done()
                flown[name] = python
                progress.print(f"compiled {name} ({module})")
            rates = {name: [] for name in flown}
            for repeat in range(args.repeats if flown else 0):
                for name, python in flown.items():
                    progress.start(f"repeat {repeat + 1}/{args.repeats}, {name}")
                    rates[name].append(measure(python, case, steps, workdir)["rate"])
                    progress.done(f"{rates[name][-1] / 1e3:,.1f}k steps/s")
                progress.print(f"repeat {repeat + 1}/{args.repeats}: " + ", ".join(
                    f"{name} {values[-1] / 1e3:,.1f}k" for name, values in rates.items()))
        if not flown:
            continue
        first = next(iter(flown))
        print(f"\n| version | steps/s (median) | ratio {first} / version: median [min, max] "
              f"| all on one side of 1 |\n|---|---|---|---|")
        for name, values in rates.items():
            ratios = [a / b for a, b in zip(rates[first], values, strict=True)]
            one_side = all(r > 1 for r in ratios) or all(r < 1 for r in ratios)
            print(f"| {name} | {statistics.median(values):,.0f} | "
                  f"{statistics.median(ratios):.3f} [{min(ratios):.3f}, {max(ratios):.3f}] | "
                  f"{'yes' if one_side else 'no'} |", flush=True)


if __name__ == "__main__":
    main()
