"""Benchmark v4's drag, fitted in the simulator's own tilted equilibrium to Neural-Fly's
measured force: ``python -m quad_dob_training.wind_tunnel.drag_fit --neural-fly DIR``.

The target is the logs' mean fa_x at 4.2, 8.5 and 12.1 m/s: each run's mean of
``flight_statistics.reconstruct_fa`` over its scored laps, averaged over the runs of a
speed (a physical measurement, not a tracking error). The simulation's side is the same
reconstruction of a vehicle holding the figure-8's centre in the tunnel's steady wind
(no turbulence, so each speed has one equilibrium) in v4's loop, tilted into the wind as
its own controller holds it: the thrust model, the rotors' speeds and inflow, and the
body's attitude are the simulator's own, not an untilted formula's. Its mean over the
last ``AVERAGED`` seconds of each flight, over ``FIT_SEEDS`` (tuning seeds).

Two coefficients are fitted, each the scale of one physical term: the body's quadratic
drag c (body x and y; z keeps the preset's ratio 0.1/0.06) and the rotors' drag
``k_d`` (``D = -k_d ω u`` per rotor). Gauss-Newton on the three speeds' residuals, the
Jacobian by finite differences of the simulation itself. It prints the fit, the residual
at each speed, and the drag exponent n of ``|fa_x| ∝ V^n`` (least squares in logs) of the
fit beside the logs'. ``quad_dob_env.benchmark_v4`` holds the result, with this
command's output in docs/benchmark-v4.md.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from quad_dob_env.benchmark_v4 import BODY_DRAG_Z_OVER_X
from quad_dob_env.params import AirframeDrag
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.trajectories import Harmonic
from quad_dob_env.wind_tunnel import FIGURE8_HEIGHT
from quad_dob_training.wind_tunnel.flight_logs import read_neural_fly_folder
from quad_dob_training.wind_tunnel.flight_statistics import log_statistics, reconstruct_fa
from quad_dob_training.wind_tunnel.tool import fly_logs

FIT_SPEEDS = (4.2, 8.5, 12.1)  # [m/s] the windy cells of Neural-Fly's tunnel
FIT_SEEDS = [100, 101, 102, 103]  # tuning seeds
HOLD = 20.0  # [s] each equilibrium flight
AVERAGED = 10.0  # [s] the last part of it, averaged
COUNTERPART = "geometric-ndob:tuned"


@dataclass(frozen=True)
class DragCoefficients:
    """The two fitted coefficients: body quadratic drag c [N/(m/s)²] in body x and y, and
    the rotors' drag k_d [N/(rad/s · m/s)]."""

    body: float
    rotor: float

    def airframe(self) -> AirframeDrag:
        return AirframeDrag(body_quadratic=(self.body, self.body,
                                            self.body * BODY_DRAG_Z_OVER_X),
                            rotor_drag_coefficient=self.rotor)


def real_mean_fa_x(folder: Path) -> dict[float, tuple[float, float, float, int]]:
    """Per wind speed: the runs' mean of their mean fa_x [N], its min, max and run count."""
    by_speed: dict[float, list[float]] = {}
    for log in read_neural_fly_folder(folder):
        if log.wind_speed is not None:
            by_speed.setdefault(float(log.wind_speed), []).append(
                log_statistics(log).mean_fa_x)
    return {speed: (float(np.mean(v)), min(v), max(v), len(v))
            for speed, v in sorted(by_speed.items())}


def equilibrium_fa_x(drag: DragCoefficients | None, speed: float,
                     seeds: list[int] = FIT_SEEDS) -> float:
    """The simulated mean fa_x [N] of v4's vehicle holding the figure-8's centre in a
    steady ``speed`` m/s (``drag`` None: v4's own), over the last ``AVERAGED`` s."""
    options = {} if drag is None else {"airframe_drag": drag.airframe()}
    centre = Harmonic(offset=(0.0, 0.0, FIGURE8_HEIGHT))
    scenario = make_scenario(f"figure8-wind-{speed:g}", benchmark="v4",
                             turbulence_intensity=0.0, duration=HOLD, **options).with_changes(
        trajectory=centre, initial_position=(0.0, 0.0, FIGURE8_HEIGHT),
        initial_velocity=(0.0, 0.0, 0.0))
    means = []
    for log in fly_logs(COUNTERPART, scenario, seeds, speed):
        if log.t[-1] < HOLD - 2 * scenario.dt:
            raise RuntimeError(f"{log.source} was lost at {log.t[-1]:.2f} s: no equilibrium")
        kept = log.t >= HOLD - AVERAGED
        means.append(float(np.nanmean(reconstruct_fa(log)[kept, 0])))
    return float(np.mean(means))


def exponent(speeds: tuple[float, ...], forces: list[float]) -> float:
    """n of |F| ∝ V^n, least squares in logs."""
    return float(np.polyfit(np.log(speeds), np.log(np.abs(forces)), 1)[0])


def fit(targets: list[float], start: DragCoefficients, iterations: int = 4,
        step: float = 0.05) -> tuple[DragCoefficients, list[float]]:
    """Gauss-Newton on the coefficients' logs (each stays positive) against ``targets``
    [N] at ``FIT_SPEEDS``, each residual relative to its target (the tolerance is
    relative); returns the best point flown and its simulated forces."""
    targets_array = np.asarray(targets)
    logs = np.log([start.body, start.rotor])

    def residuals(point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        drag = DragCoefficients(*np.exp(point))
        forces = np.array([equilibrium_fa_x(drag, speed) for speed in FIT_SPEEDS])
        return (forces - targets_array) / np.abs(targets_array), forces

    current, forces = residuals(logs)
    best = (float(current @ current), logs, forces)
    for _ in range(iterations):
        jacobian = np.column_stack([(residuals(logs + step * np.eye(2)[k])[0] - current) / step
                                    for k in range(2)])
        change = np.linalg.lstsq(jacobian, -current, rcond=None)[0]
        logs = logs + np.clip(change, -1.0, 1.0)  # at most a factor e a step
        current, forces = residuals(logs)
        print(f"  body {math.exp(logs[0]):.5f} N/(m/s)², rotor k_d {math.exp(logs[1]):.4e}: "
              + ", ".join(f"{f:.2f}" for f in forces) + " N", flush=True)
        if float(current @ current) < best[0]:
            best = (float(current @ current), logs, forces)
    return DragCoefficients(*np.exp(best[1])), list(best[2])


def main(neural_fly: Path, start: DragCoefficients) -> None:
    real = real_mean_fa_x(neural_fly)
    targets = [real[speed][0] for speed in FIT_SPEEDS]
    print("Neural-Fly's mean fa_x over each speed's runs [N]: " + ", ".join(
        f"{speed:g} m/s {real[speed][0]:.2f} ({real[speed][1]:.2f} to {real[speed][2]:.2f}, "
        f"{real[speed][3]} runs)" for speed in FIT_SPEEDS))
    before = [equilibrium_fa_x(start, speed) for speed in FIT_SPEEDS]
    print(f"start: body {start.body:.5f}, rotor k_d {start.rotor:.4e}: "
          + ", ".join(f"{f:.2f}" for f in before) + " N")
    fitted, forces = fit(targets, start)
    z = fitted.body * BODY_DRAG_Z_OVER_X
    print(f"\nfitted: body c = {fitted.body:.5f} N/(m/s)² (z {z:.5f}), "
          f"rotor k_d = {fitted.rotor:.4e} N/(rad/s·m/s)")
    print("| wind [m/s] | logs' mean fa_x [N] | v3's drag in v4's loop [N] | fitted [N] | "
          "residual |")
    print("|---|---|---|---|---|")
    for speed, target, was, now in zip(FIT_SPEEDS, targets, before, forces, strict=True):
        print(f"| {speed:g} | {target:.2f} | {was:.2f} | {now:.2f} | "
              f"{100 * (now - target) / abs(target):+.1f} % |")
    logs_n, before_n, fitted_n = (exponent(FIT_SPEEDS, values)
                                  for values in (targets, before, forces))
    print(f"drag exponent n (|fa_x| ∝ V^n over 4.2-12.1 m/s): logs {logs_n:.2f}, "
          f"v3's drag {before_n:.2f}, fitted {fitted_n:.2f}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--neural-fly", type=Path, required=True,
                        help="Neural-Fly's data/experiment folder (read on this machine only)")
    parser.add_argument("--body", type=float, default=None,
                        help="the body drag to start from (default: the preset's)")
    parser.add_argument("--rotor", type=float, default=None,
                        help="the rotor drag k_d to start from (default: the preset's)")
    args = parser.parse_args()
    from quad_dob_env.params import VEHICLES
    preset = VEHICLES["neural-fly"]
    main(args.neural_fly, DragCoefficients(args.body or preset.drag_quadratic[0],
                                           args.rotor or preset.rotor_drag_coefficient))
