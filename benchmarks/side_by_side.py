"""Throughput of the working tree beside named commits, interleaved in one run.

Run by hand: ``python benchmarks/side_by_side.py --commits 5a52e7e --repeats 7``. Each
commit is checked out in a git worktree under ``--workdir`` and imported from there through
a folder of links named as the packages install (``quad_dob_env``, ``quad_dob_baselines``,
``quad_dob_composition``, ``quad_dob_training``) put first on ``PYTHONPATH``, so the
installed project is never touched. Every repeat of every case is a fresh process on a warm
numba cache (one untimed process per version compiles first), run in the order A B C A B C
..., so the machine's drift falls on every version alike. It prints each version's median
env-steps/s and each version's ratio to the first (the working tree): median, min and max of
the per-repeat ratios.

The cases are the vector env of a residual id flown with a zero residual (the base in the
loop) at N vehicles: ``TrackResidual-v1`` on ``paper-none`` and ``TrackResidual-v3`` on
``dryden-helix-gusts`` by default.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"quad_dob_env": "quad_dob_env", "quad_dob_baselines": "baselines",
            "quad_dob_composition": "composition", "quad_dob_training": "training"}
CASES = {"v1 paper-none": ("QuadDOB/TrackResidual-v1", "paper-none"),
         "v3 dryden-helix-gusts": ("QuadDOB/TrackResidual-v3", "dryden-helix-gusts")}

# One measurement, run in a fresh process: env-steps per second of STEPS steps after three
# that compile and warm up.
MEASURE = """
import json, sys, time
import gymnasium as gym
import numpy as np
import quad_dob_env
env_id, scenario, n, steps = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
env = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point",
                   scenario=scenario)
env.reset(seed=0)
actions = np.zeros((n, 4))
for _ in range(3):
    env.step(actions)
start = time.perf_counter()
for _ in range(steps):
    env.step(actions)
print(json.dumps({"rate": n * steps / (time.perf_counter() - start),
                  "module": quad_dob_env.__file__}))
"""


def links_for(tree: Path, workdir: Path, name: str) -> Path:
    """A folder of links that makes ``tree``'s folders import under the installed names."""
    folder = workdir / f"links-{name}"
    folder.mkdir(parents=True, exist_ok=True)
    for installed, source in PACKAGES.items():
        link = folder / installed
        if link.is_symlink():
            link.unlink()
        link.symlink_to(tree / source)
    return folder


def checkout(commit: str, workdir: Path) -> Path:
    """A worktree of ``commit`` under ``workdir`` (made once, reused)."""
    tree = workdir / f"tree-{commit}"
    if not tree.exists():
        print(f"checking out {commit} into {tree} ...", flush=True)
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree),
                        commit], check=True, capture_output=True)
    return tree


def measure(links: Path, env_id: str, scenario: str, n: int, steps: int) -> dict:
    environment = {**os.environ, "PYTHONPATH": str(links)}
    result = subprocess.run([sys.executable, "-c", MEASURE, env_id, scenario, str(n),
                             str(steps)], env=environment, capture_output=True, text=True,
                            cwd=links)
    if result.returncode:
        raise RuntimeError(f"measurement failed under {links}:\n{result.stderr[-2000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--commits", default="5a52e7e",
                        help="comma-separated commits to set beside the working tree")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--vehicles", type=int, default=1024)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--cases", default=",".join(CASES),
                        help=f"comma-separated, of: {', '.join(CASES)}")
    parser.add_argument("--workdir", default="/tmp/quad-dob-side-by-side")
    args = parser.parse_args()
    workdir = Path(args.workdir)
    versions = {"working tree": links_for(ROOT, workdir, "working-tree")}
    for commit in filter(None, args.commits.split(",")):
        versions[commit] = links_for(checkout(commit, workdir), workdir, commit)
    cases = [case.strip() for case in args.cases.split(",")]
    for case in cases:
        env_id, scenario = CASES[case]
        print(f"\n## {case}: {env_id} on {scenario}, N = {args.vehicles}, "
              f"{args.steps} steps, {args.repeats} interleaved repeats", flush=True)
        for name, links in versions.items():  # compiles into each version's cache
            module = measure(links, env_id, scenario, args.vehicles, 3)["module"]
            print(f"compiled {name} ({module})", flush=True)
        rates: dict[str, list[float]] = {name: [] for name in versions}
        for repeat in range(args.repeats):
            for name, links in versions.items():
                rates[name].append(measure(links, env_id, scenario, args.vehicles,
                                           args.steps)["rate"])
            print(f"repeat {repeat + 1}/{args.repeats}: " + ", ".join(
                f"{name} {values[-1] / 1e3:,.0f}k" for name, values in rates.items()),
                flush=True)
        first = next(iter(versions))
        print("\n| version | env-steps/s (median) | ratio of working tree to it: median "
              "[min, max] |\n|---|---|---|")
        for name, values in rates.items():
            ratios = [a / b for a, b in zip(rates[first], values, strict=True)]
            print(f"| {name} | {statistics.median(values):,.0f} | "
                  f"{statistics.median(ratios):.3f} [{min(ratios):.3f}, {max(ratios):.3f}] |")


if __name__ == "__main__":
    main()
