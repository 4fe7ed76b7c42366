"""L2F's vector env beside ours, on one machine in one run (issue 58).

L2F (rl-tools/l2f, the simulator of "Learning to Fly in Seconds") compiles its vector env,
C++ with OpenMP and ``-march=native``, once per batch size: fourteen sizes, 1 to 8192, in one
extension (``l2f.vector_selector``). It is no dependency of this project nor of
``make test``: build it apart (docs/speed.md has the build's time), then point Python at it:

    pip install --no-deps --no-binary l2f --target /tmp/l2f_site l2f==2.0.18
    PYTHONPATH=/tmp/l2f_site python benchmarks/l2f_speed.py

Without it the script prints one line saying so and exits 0.

At each of L2F's compiled sizes N (``--sizes`` for fewer), interleaved, the median of
``--repeats`` (env-steps per second; a step is 10 ms of simulated time on both sides):

- **L2F step**: ``vector.step`` alone, the hover command to every vehicle. Per vehicle: one
  RK4 step of 10 ms (four evaluations) of the rigid body (quaternion attitude, float32) and
  the rotors' first-order speed lag (rising 55 ms, falling 249 ms, integrated in the same
  RK4), thrust and torque quadratic in rotor speed; then the quaternion renormalised, the
  state clamped and the action written into a 16-step history. No wind, drag, sensing nor
  controller.
- **L2F RL step**: what an RL loop needs of a step, in the order of L2F's own SB3 wrapper
  (``l2f/wrappers/sb3.py``, without its per-vehicle Python loop of info dicts, its second
  ``observe`` and its copy of the state, where the two states swap roles here): ``step``,
  ``reward``, ``terminated`` (position 1 m, velocity 2 m/s, rate 35 rad/s), the 500-step
  limit, ``sample_initial_parameters_if_truncated`` and ``sample_initial_state_if_truncated``
  for the vehicles done, ``observe`` (82 numbers). Six OpenMP loops and a little numpy.
- **ours v4**: ``QuadDOB/TrackResidual-v4`` (the tools' default benchmark) on its scenario,
  ``dryden-helix-gusts``, a zero residual, so the base ``geometric-ndob:tuned`` flies: the
  full loop, sensing and the 200 Hz inner loop included (docs/speed.md writes out a step).
- **ours like for like**: the same with ``sensing="ideal"`` and ``inner_rate=0``: the
  nearest to L2F's step that the loop has, and still more work than it (the controller,
  the wind, the drag, the observation, the reward, the info).

L2F runs in a child process per thread count (``--l2f-threads``, each its
``OMP_NUM_THREADS``): OpenMP's threads keep spinning a while after each loop, and in our
process they would take the core our second thread needs. A measurement of L2F stops at
``--l2f-seconds`` (the steps done count): where another process holds a core, OpenMP's
barriers can slow its two threads a hundredfold. Ours runs on two threads
(``quad_dob_env.threads``; batches under 256 vehicles run on one); where this process may
run on more than ``--cores`` cores it is held to that many, and so are the children.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any, TextIO

import gymnasium as gym
import numpy as np

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_composition.fused import FusedResidualStep
from quad_dob_env.threads import PARALLEL_MIN_BATCH, worker_count
from quad_dob_training.progress import Progress, compiling_notice

# throughput.py's timing, reused as it is (a reset, three steps to compile and warm up, then
# the timed steps from a reset): the script's folder is on the path when it runs as a
# script, not when a test loads it from its file
sys.path.insert(0, str(Path(__file__).resolve().parent))
from throughput import compiled_and_warm, timed_env_steps_per_second

L2F_VERSION = "2.0.18"
MISSING = (f"l2f_speed: l2f is not importable ({{error}}); it is no dependency of this "
           f"project: pip install --no-deps --no-binary l2f --target /tmp/l2f_site "
           f"l2f=={L2F_VERSION}, then PYTHONPATH=/tmp/l2f_site python benchmarks/l2f_speed.py")
OUR_ID = "QuadDOB/TrackResidual-v4"
# the loop with sensing and the inner loop off (``LoopOptions``: "ideal" holds under v4,
# where None would take its mocap; an inner rate of 0 means none)
LIKE_FOR_LIKE = {"sensing": "ideal", "inner_rate": 0}
OURS = {"ours v4": None, "ours like": LIKE_FOR_LIKE}
MODES = ("step", "RL")  # L2F's step alone, and what an RL loop calls a step


def load_l2f() -> ModuleType | str:
    """``l2f`` when it imports, else why not (the import's error, in words)."""
    try:
        return importlib.import_module("l2f")
    except ImportError as error:
        return str(error)


def hover_action(l2f: ModuleType) -> float:
    """The normalised rotor command whose thrust carries the weight of L2F's nominal
    vehicle (its own thrust curve, mass and gravity, read from its parameters' JSON).
    Without a controller its vehicles drift from their random starts and are reset, as in
    an RL loop's first steps."""
    device, env, parameters = l2f.Device(), l2f.Environment(), l2f.Parameters()
    l2f.initialize_environment(device, env)
    l2f.initial_parameters(device, env, parameters)
    dynamics = json.loads(l2f.parameters_to_json(device, env, parameters))["dynamics"]
    c0, c1, c2 = dynamics["rotor_thrust_coefficients"][0]
    per_rotor = dynamics["mass"] * -dynamics["gravity"][2] / len(dynamics["rotor_positions"])
    speed = (-c1 + np.sqrt(c1 * c1 - 4 * c2 * (c0 - per_rotor))) / (2 * c2)
    low, high = dynamics["action_limit"]["min"], dynamics["action_limit"]["max"]
    return float(2 * (speed - low) / (high - low) - 1)


class L2FVector:
    """L2F's env of ``n`` vehicles, set up as its SB3 wrapper sets it up: generators seeded
    ``seed + i``, parameters and start states sampled; every vehicle given ``action``."""

    def __init__(self, l2f: ModuleType, n: int, action: float, seed: int = 0) -> None:
        self.vector = vector = l2f.vector_selector[n]
        self.device = l2f.Device()
        self.rng = vector.VectorRng()
        vector.initialize_rng(self.device, self.rng, seed)
        self.env = vector.VectorEnvironment()
        vector.initialize_environment(self.device, self.env)
        self.parameters = vector.VectorParameters()
        vector.sample_initial_parameters(self.device, self.env, self.parameters, self.rng)
        self.state, self.next_state = vector.VectorState(), vector.VectorState()
        vector.sample_initial_state(self.device, self.env, self.parameters, self.state,
                                    self.rng)
        self.actions = np.full((n, self.env.ACTION_DIM), action, dtype=np.float32)
        self.observation = np.empty((n, self.env.OBSERVATION_DIM), dtype=np.float32)
        self.rewards = np.empty(n, dtype=np.float32)
        self.terminated = np.empty(n, dtype=bool)
        self.episode_step = np.zeros(n, dtype=np.int64)
        self.limit = self.env.EPISODE_STEP_LIMIT
        self.dt = 0.0  # [s] simulated by the last step, as L2F's step returns it
        self.steps = self.resets = 0  # steps taken, vehicles reset by ``rl_step``, so far

    def step(self) -> None:
        """``vector.step`` alone; the two states swap roles (no copy)."""
        dts = self.vector.step(self.device, self.env, self.parameters, self.state,
                               self.actions, self.next_state, self.rng)
        self.dt = dts[0]
        self.steps += 1
        self.state, self.next_state = self.next_state, self.state

    def rl_step(self) -> None:
        """A step as an RL loop needs it: the step, its reward and termination, the time
        limit, a fresh start for the vehicles done, their observation."""
        v, device, env, parameters, rng = (self.vector, self.device, self.env,
                                           self.parameters, self.rng)
        dts = v.step(device, env, parameters, self.state, self.actions, self.next_state, rng)
        self.dt = dts[0]
        v.reward(device, env, parameters, self.state, self.actions, self.next_state,
                 self.rewards, rng)
        # the wrapper asks the state before the step; the one after is the one that ended
        v.terminated(device, env, parameters, self.next_state, self.terminated, rng)
        self.episode_step += 1
        done = self.terminated | (self.episode_step >= self.limit)
        v.sample_initial_parameters_if_truncated(device, env, parameters, done, rng)
        v.sample_initial_state_if_truncated(device, env, parameters, self.next_state, done,
                                            rng)
        self.episode_step[done] = 0
        self.resets += int(np.count_nonzero(done))
        v.observe(device, env, parameters, self.next_state, self.observation, rng)
        self.steps += 1
        self.state, self.next_state = self.next_state, self.state

    def rate(self, mode: str, steps: int, seconds: float = float("inf")) -> float:
        """Env-steps per second of ``steps`` calls of ``step`` or ``rl_step`` (``mode``),
        fewer where they would take more than ``seconds``: on a core shared with another
        process OpenMP's barriers can slow two threads a hundredfold, and the run would
        take an hour."""
        advance = self.step if mode == "step" else self.rl_step
        start = now = time.perf_counter()
        done = 0
        while done < steps and (done == 0 or now - start < seconds):
            advance()
            done += 1
            now = time.perf_counter()
        return len(self.actions) * done / (now - start)


def serve_l2f(requests: TextIO, answers: TextIO) -> None:
    """The child's loop: each request a JSON line ``{"n", "mode", "steps", "seconds"}``,
    each answer one (the rate, the step's dt, the steps taken, the share of vehicle-steps
    reset). Envs are built at a size's first request and kept; a request of 0 steps builds
    and warms one up."""
    l2f = load_l2f()
    if isinstance(l2f, str):
        raise SystemExit(MISSING.format(error=l2f))
    action, envs = hover_action(l2f), {}
    for line in requests:
        request = json.loads(line)
        n, mode, steps, seconds = (request[key] for key in ("n", "mode", "steps", "seconds"))
        if n not in envs:
            envs[n] = L2FVector(l2f, n, action)
        env = envs[n]
        steps_before, resets_before = env.steps, env.resets
        if steps == 0:  # the first loops start OpenMP's threads and touch the memory
            env.rate("step", 10)
            env.rate("RL", 10)
            answer = {"rate": 0.0, "dt": env.dt, "steps": 0, "reset_share": 0.0}
        else:
            rate = env.rate(mode, steps, seconds)
            answer = {"rate": rate, "dt": env.dt, "steps": env.steps - steps_before,
                      "reset_share": (env.resets - resets_before)
                      / (n * (env.steps - steps_before))}
        answers.write(json.dumps(answer) + "\n")
        answers.flush()


class L2FChild:
    """This script in a child process serving L2F's measurements with ``threads`` OpenMP
    threads (``serve_l2f``)."""

    def __init__(self, threads: int) -> None:
        self.threads = threads
        environment = {**os.environ, "OMP_NUM_THREADS": str(threads)}
        self.process = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--serve-l2f"], env=environment,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def measure(self, n: int, mode: str, steps: int,
                seconds: float = float("inf")) -> dict[str, float]:
        """The child's answer to one request (``serve_l2f``)."""
        assert self.process.stdin is not None and self.process.stdout is not None
        request = {"n": n, "mode": mode, "steps": steps, "seconds": seconds}
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        answer = self.process.stdout.readline()
        if not answer:
            raise RuntimeError(f"L2F's child process (OMP_NUM_THREADS={self.threads}) ended: "
                               "its error is above")
        return json.loads(answer)

    def close(self) -> None:
        if self.process.stdin is not None:
            self.process.stdin.close()
        self.process.wait(timeout=30)


def our_env(n: int, scenario_options: dict[str, Any] | None) -> Any:
    """``OUR_ID`` as ``n`` vehicles, its loop changed by ``scenario_options``."""
    return gym.make_vec(OUR_ID, num_envs=n, vectorization_mode="vector_entry_point",
                        scenario_options=scenario_options)


def flown(env: Any) -> tuple[float, bool]:
    """What ``env`` steps by: its control step [s], and whether one compiled pass a step
    flies it (``FusedResidualStep``) or its stages do, one compiled call each."""
    core = env.unwrapped.core
    return core.scenario.dt, FusedResidualStep.flies(core)


def warm_up() -> None:
    """Both of our envs at two vehicles, stepped: a first run compiles the kernels here,
    under a notice, not in the first measurement's silence."""
    with compiling_notice():
        for options in OURS.values():
            compiled_and_warm(our_env(2, options))


def steps_for(n: int, vehicle_steps: int, fewest: int = 20, most: int = 2000) -> int:
    """Steps to time at ``n`` vehicles: ``vehicle_steps`` of them in all, within
    [``fewest``, ``most``]."""
    return max(fewest, min(most, vehicle_steps // n))


def hold_to_cores(cores: int) -> int:
    """Hold this process (and the children it starts) to ``cores`` of the cores it may run
    on; the cores it runs on after."""
    if not hasattr(os, "sched_setaffinity"):  # not on Linux: left as it is
        return worker_count()
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) > cores:
        os.sched_setaffinity(0, allowed[:cores])
        worker_count.cache_clear()  # ours splits a batch over the cores it may run on
    return len(os.sched_getaffinity(0))


def columns(threads: list[int]) -> list[str]:
    """The rate table's columns after N: L2F's, by mode and thread count, then ours."""
    return [f"L2F {mode} {k}t" for mode in MODES for k in threads] + list(OURS)


def ratio(l2f: list[float], ours: list[float]) -> str:
    """L2F over ours, per interleaved repeat: median [min, max]."""
    ratios = [a / b for a, b in zip(l2f, ours, strict=True)]
    return f"{statistics.median(ratios):.3g} [{min(ratios):.3g}, {max(ratios):.3g}]"


def load() -> str:
    """The machine's load averages over 1, 5 and 15 minutes."""
    return ", ".join(f"{value:.2f}" for value in os.getloadavg())


def cpu_model() -> str:
    """The CPU's model name, as Linux reports it."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="all",
                        help="comma-separated batch sizes among L2F's compiled ones (all: "
                             "the fourteen)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="interleaved repeats per size (the median is reported)")
    parser.add_argument("--vehicle-steps", type=int, default=120_000,
                        help="vehicle-steps timed per measurement (steps = this / N, "
                             "within 20-2000)")
    parser.add_argument("--l2f-threads", default="1,2",
                        help="comma-separated OMP_NUM_THREADS for L2F, one child each")
    parser.add_argument("--l2f-seconds", type=float, default=0.5,
                        help="at most this long a measurement of L2F (fewer steps, where a "
                             "loaded machine slows its threads)")
    parser.add_argument("--cores", type=int, default=2,
                        help="cores to hold the run to (ours runs a thread on each)")
    parser.add_argument("--serve-l2f", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve_l2f:
        serve_l2f(sys.stdin, sys.stdout)
        return
    l2f = load_l2f()
    if isinstance(l2f, str):
        print(MISSING.format(error=l2f))
        return
    compiled = sorted(l2f.vector_selector)
    sizes = compiled if args.sizes == "all" else [int(n) for n in args.sizes.split(",")]
    if not set(sizes) <= set(compiled):
        parser.error(f"--sizes must be among L2F's compiled sizes {compiled}, got {sizes}")
    threads = [int(k) for k in args.l2f_threads.split(",")]
    cores = hold_to_cores(args.cores)
    print(f"l2f_speed: L2F (OMP_NUM_THREADS {', '.join(map(str, threads))}) and ours "
          f"({', '.join(OURS)}) at {len(sizes)} batch sizes x {args.repeats} interleaved "
          "repeats", file=sys.stderr, flush=True)
    warm_up()
    children = {k: L2FChild(k) for k in threads}
    names = columns(threads)
    loops: dict[str, tuple[float, bool]] = {}
    rates: dict[tuple[int, str], list[float]] = {}
    resets: list[float] = []
    cut = 0  # L2F's measurements stopped at --l2f-seconds
    dt_l2f: set[float] = set()
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores, the run held to {cores}; load "
          f"average {load()} at the start")
    print(f"Python {platform.python_version()}, numpy {np.__version__}, l2f from "
          f"{Path(l2f.__file__).parent}")
    print(f"ours: {OUR_ID}, a zero residual, {worker_count()} threads (batches under "
          f"{PARALLEL_MIN_BATCH} vehicles on one)")
    openmp = [f"{key}={value}" for key, value in sorted(os.environ.items())
              if key.startswith(("OMP_", "GOMP_"))]
    print(f"L2F: a child process per thread count, OpenMP's other settings "
          f"{', '.join(openmp) or 'its defaults'}; median env-steps/s of {args.repeats} "
          "interleaved repeats\n")
    print("| N | " + " | ".join(names) + " |")
    print("|---" * (len(names) + 1) + "|")
    try:
        with Progress("l2f_speed", len(sizes) * (1 + args.repeats)) as progress:
            for n in sizes:
                progress.start(f"N = {n}: building and warming")
                envs = {name: our_env(n, options) for name, options in OURS.items()}
                for env in envs.values():
                    compiled_and_warm(env)
                for child in children.values():
                    child.measure(n, "step", 0)
                loops = {name: flown(env) for name, env in envs.items()}
                progress.done()
                steps = steps_for(n, args.vehicle_steps)
                zeros = np.zeros((n, 4))  # a zero residual: the base flies alone
                for repeat in range(args.repeats):
                    progress.start(f"N = {n}, repeat {repeat + 1}/{args.repeats}")
                    for mode in MODES:
                        for k, child in children.items():
                            answer = child.measure(n, mode, steps, args.l2f_seconds)
                            rates.setdefault((n, f"L2F {mode} {k}t"), []).append(answer["rate"])
                            dt_l2f.add(round(answer["dt"], 6))
                            cut += answer["steps"] < steps
                            if mode == "RL":
                                resets.append(answer["reset_share"])
                    for name, env in envs.items():
                        rates.setdefault((n, name), []).append(
                            timed_env_steps_per_second(env, zeros, steps))
                    progress.done()
                progress.print(f"| {n} | " + " | ".join(
                    f"{statistics.median(rates[n, name]):,.0f}" for name in names) + " |")
                del envs
    finally:
        for child in children.values():
            child.close()
    print(f"\nsimulated time a step: L2F's step returned dt = {sorted(dt_l2f)} s; "
          + ", ".join(f"{name} {dt:g} s" for name, (dt, _) in loops.items()))
    print("simulated seconds per wall second: env-steps/s x dt on both sides")
    print("ours, in one compiled pass a step (FusedResidualStep): " + ", ".join(
        f"{name} {'yes' if fused else 'no, as stages'}" for name, (_, fused) in loops.items()))
    if resets:
        print(f"L2F RL step: {statistics.median(resets):.2%} of vehicle-steps reset "
              "(median over its measurements)")
    print(f"L2F's measurements cut short at {args.l2f_seconds:g} s: {cut} of "
          f"{len(sizes) * args.repeats * len(MODES) * len(threads)}")
    print(f"load average {load()} at the end")
    for k in threads:
        pairs = [(f"L2F {mode} {k}t", name) for mode in MODES for name in OURS]
        print(f"\nL2F / ours, per interleaved repeat: median [min, max]; L2F on {k} "
              f"thread{'s' * (k > 1)}, ours on {worker_count()}\n")
        print("| N | " + " | ".join(f"{a} / {b}" for a, b in pairs) + " |")
        print("|---" * (len(pairs) + 1) + "|")
        for n in sizes:
            print(f"| {n} | " + " | ".join(ratio(rates[n, a], rates[n, b]) for a, b in pairs)
                  + " |")


if __name__ == "__main__":
    main()
