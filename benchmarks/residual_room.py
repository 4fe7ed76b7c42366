"""How much room a residual has over its base: the base flown with hand-built corrections.

A learned residual can only take what its inputs and its loop leave. This script flies a
base controller through ``ResidualVectorEnv``'s acceleration residual with two corrections
built by hand from inputs a real stack has, at several gains, and prints the RMS position
error after the first fifth of each flight beside the base's own (gain 0):

- ``lead``: ``Δa = τ j_d``, the reference's jerk (the planner's) times a lead time τ [s]. It
  asks whether the motors' lag and the latency leave a feed-forward error to take.
- ``specific-force``: ``Δa = -k (LP_fc(R (f - T_c e3 / m)) - d̂ / m)``. f is the
  accelerometer's body-frame specific force, T_c the thrust the autopilot commanded over the
  last step, m the nominal mass (so ``R (f - T_c e3 / m)`` is what the IMU says the
  disturbance is, at once: ``m a = m g + R T e3 + d``, O'Connell et al. 2022), LP a first-order
  low-pass at fc [Hz], d̂ the observer's estimate. It asks how much a faster disturbance
  estimate than the base's gains.

    python benchmarks/residual_room.py --scenarios random-tracks,hover-step-force \\
        --lead 0.02,0.04 --specific-force 0.5/5,1/10 --seeds 10000-10015

docs/residual-v4.md uses it for the room Benchmark v4's loop leaves a residual.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from quad_dob_composition import make_vector_env
from quad_dob_env.envs import observation_table
from quad_dob_env.residual import ResidualOptions
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.progress import Progress, compiling_notice
from quad_dob_training.rollout import warm_up_copy

ACCELERATION_SCALE = 3.0  # [m/s²] per unit action: no correction here comes near it
# the observer's force estimate among the acceleration residual's observation entries
FORCE_ESTIMATE = next(entry.columns for entry in observation_table(
    residual=ResidualOptions(residual_mode="acceleration")) if entry.name == "force_estimate")
# a correction's law: (env, observations) -> the residual's acceleration [m/s²] (N, 3)
Correction = Callable[[object, NDArray[np.float64]], NDArray[np.float64]]


def lead(lead_time: float) -> Correction:
    """``Δa = τ j_d``: the reference's jerk times ``lead_time`` [s]."""
    def law(env: object, observations: NDArray[np.float64]) -> NDArray[np.float64]:
        core = env.core
        return lead_time * core.reference_table[core.reference_row, 3]
    return law


def specific_force(gain: float, cutoff: float, dt: float) -> Correction:
    """``Δa = -k (LP(R (f - T_c e3 / m)) - d̂ / m)`` with a first-order low-pass at
    ``cutoff`` [Hz], discretised exactly at the control period ``dt``."""
    alpha = 1.0 - np.exp(-2.0 * np.pi * cutoff * dt)
    filtered: NDArray[np.float64] | None = None  # starts at the first sample

    def law(env: object, observations: NDArray[np.float64]) -> NDArray[np.float64]:
        nonlocal filtered
        core = env.core
        measurement, vehicle = core.measurement, core.vehicle
        specific = measurement.accelerometer.copy()
        specific[:, 2] -= core.commanded.thrust / vehicle.mass
        measured = np.einsum("nij,nj->ni", measurement.rotation, specific)
        filtered = measured if filtered is None else filtered + alpha * (measured - filtered)
        # the observation's force estimate is d̂ / (m g)
        estimate = vehicle.gravity * observations[:, FORCE_ESTIMATE]
        return -gain * (filtered - estimate)
    return law


def settled_rms(scenario: str, base: str, seeds: list[int],
                correction: Correction | None, warm_up: bool = False) -> float:
    """RMS ‖x - x_d‖ [m] after the first fifth of each flight, all seeds together.
    ``warm_up``: the scenario's first few steps only (``rollout.warm_up_copy``), which
    compile its kernels on a first run."""
    flown = make_scenario(scenario, benchmark="v4")
    if warm_up:
        flown = warm_up_copy(flown)
    env = make_vector_env(len(seeds), flown, base_controller=base,
                          residual_mode="acceleration", acceleration_scale=ACCELERATION_SCALE)
    observations, _ = env.reset(seed=seeds)
    actions = np.zeros((len(seeds), 4))
    errors = []
    for _ in range(flown.steps):
        if correction is not None:
            actions[:, :3] = np.clip(correction(env, observations) / ACCELERATION_SCALE,
                                     -1.0, 1.0)
        observations, *_ = env.step(actions)
        core = env.core
        errors.append(core.state.position - core.reference_table[core.reference_row, 0])
    settled = np.array(errors)[flown.steps // 5:]
    return float(np.sqrt((settled ** 2).sum(axis=-1).mean()))


def _floats(text: str) -> list[float]:
    return [float(value) for value in text.split(",") if value]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", default="random-tracks,hover-step-force,gusty-hover,"
                        "figure8-wind-8.5", help="Benchmark v4 scenarios, comma-separated")
    parser.add_argument("--base", default="geometric-ndob:tuned")
    parser.add_argument("--lead", default="0.02,0.04,0.06", help="lead times τ [s]")
    parser.add_argument("--specific-force", default="0.5/5,1/5,0.5/10,1/10",
                        help="gain/cutoff pairs: k [-] / fc [Hz]")
    parser.add_argument("--seeds", default="10000-10015")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    pairs = [tuple(float(v) for v in pair.split("/"))
             for pair in args.specific_force.split(",") if pair]
    if any(len(pair) != 2 for pair in pairs):
        parser.error(f"--specific-force takes gain/cutoff pairs such as 1/10, got "
                     f"{args.specific_force!r}")
    scenarios = args.scenarios.split(",")
    leads = _floats(args.lead)
    print(f"residual_room: {len(scenarios)} scenarios x (the base, {len(leads)} leads, "
          f"{len(pairs)} specific-force filters) x {len(seeds)} seeds", file=sys.stderr,
          flush=True)
    # a first run compiles the kernels here, under a notice
    with compiling_notice():
        for scenario in scenarios:
            settled_rms(scenario, args.base, seeds, None, warm_up=True)
    print(f"{args.base} in Benchmark v4, seeds {args.seeds}: RMS position after the first "
          "fifth [mm], and against the base")
    with Progress("residual_room", len(scenarios) * (1 + len(leads) + len(pairs))) as progress:
        for scenario in scenarios:
            dt = make_scenario(scenario, benchmark="v4").dt
            progress.start(f"{scenario}, base")
            base = 1000 * settled_rms(scenario, args.base, seeds, None)
            progress.done(f"{base:.1f} mm")
            progress.print(f"{scenario:22} base {base:6.1f}")
            corrections = ([(f"lead {tau:g} s", lead(tau)) for tau in leads]
                           + [(f"specific-force k {k:g} fc {fc:g} Hz",
                               specific_force(k, fc, dt)) for k, fc in pairs])
            for label, correction in corrections:
                progress.start(f"{scenario}, {label}")
                rms = 1000 * settled_rms(scenario, args.base, seeds, correction)
                progress.done(f"{rms:.1f} mm")
                progress.print(f"{'':22} {label:30} {rms:6.1f}  "
                               f"({100 * (rms / base - 1):+.0f} %)")


if __name__ == "__main__":
    main()
