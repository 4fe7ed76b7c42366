"""``quad-dob tune``: every baseline's gains by one documented procedure, on tuning seeds.

The procedure, the same for each controller:

- **Seeds and scenarios.** ``TUNING_SEEDS`` (100-109) on ``TUNING_SCENARIOS``: the v1
  scenarios with physical rotors and wind, and two variants made for tuning
  (``TUNING_VARIANTS``): a hover with a step of force *and torque* (no wind scenario
  applies a torque, so without it the observer's rotational rate could not be told apart)
  and the paper's helix from a perturbed start. Evaluation uses seeds 9001-9020 and the
  unperturbed paper scenarios, never looked at here.
- **Objective.** The mean over the scenarios of the mean over seeds of the RMS position
  error after t = 2 s; a flight that ends early counts as ``LOST_FLIGHT`` (1 m), so a gain
  that loses vehicles never wins.
- **Search.** Coordinate descent from the hand-set gains in ``START``: each gain in turn tries its
  default times ``FACTORS`` with the others held, and keeps the best; two passes over all
  gains. The observer rates of geometric + NDOB are a grid (``OBSERVER_RATES``) instead,
  since there are only two and they interact; among rates within ``TIE_TOLERANCE`` (2 %) of
  the best objective the slowest wins, since a faster observer amplifies what the benchmark
  does not model (sensor noise, delay) and buys almost nothing here.

The geometric controller's own gains (kx, kv, kR, kΩ) go through the same descent from
Lee 2010's, with the observer at its tuned rates (``quad-dob tune --controllers
geometric-ndob:tuned``); the winner is ``geometric-ndob:gains-tuned``, a baseline beside
the recommended base, which keeps the paper's gains.

The winners are what ``baselines`` ships as defaults (``PID_GAINS``, ``SMC_GAINS``,
``TUNED_OBSERVER_RATES``, ``TUNED_GEOMETRIC_GAINS``); ``quad-dob tune`` prints the search
so it can be checked and rerun. The SMC's switching gain is not searched: it follows from
its disturbance bound.
"""

from __future__ import annotations

import itertools
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from quad_dob_baselines import (
    GeometricController,
    NonlinearDisturbanceObserver,
    make_controller,
)
from quad_dob_baselines.base import Controller
from quad_dob_baselines.geometric import PAPER_GAINS
from quad_dob_baselines.pid import PID_GAINS
from quad_dob_baselines.smc import SMC_GAINS
from quad_dob_env.disturbances import Constant
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.metrics import flight_metrics
from quad_dob_training.policies import Policy, fly_policy

TUNING_SEEDS = tuple(range(100, 110))
TUNING_SCENARIOS = ("dryden-helix-gusts", "gusty-hover", "takeoff-landing-wind",
                    "hover-step-wrench", "paper-helix-perturbed")
# Tuning-only variants: hover-step-force's push plus a body torque for 3 <= t < 6 s; the
# paper's helix (wrench actuation, heading turning at π rad/s, started 0.6 m off the
# reference) from a start perturbed by ±0.1 m and ±0.1 rad, so gains that only suit the
# wind scenarios do not win.
TUNING_VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "hover-step-wrench": ("hover-step-force", {"disturbance": Constant(
        force=(0.2 * get_vehicle("paper").hover_thrust, 0.0, 0.0),
        torque=(0.3, 0.3, 0.1)).during(3.0, 6.0)}),
    "paper-helix-perturbed": ("paper-none", {"initial_position_noise": 0.1,
                                             "initial_attitude_noise": 0.1}),
}
TIE_TOLERANCE = 0.02
LOST_FLIGHT = 1.0  # [m] what a flight that ended early scores
FACTORS = (0.5, 0.7, 1.4, 2.0)
PASSES = 2
# The grid stops at 40 /s: a discrete observer's bandwidth is kept under a tenth of the
# sampling rate (2π 100 Hz / 10 = 63 rad/s), beyond which the sensor noise and delay that
# the benchmark does not model would dominate. Noise-free, faster always scores a little
# better (80 /s scored 0.0222 m against 0.0236 m at 40 /s in a first run of this search).
OBSERVER_RATES = {"translational_rate": (1.0, 2.0, 5.0, 10.0, 20.0, 40.0),
                  "rotational_rate": (2.0, 5.0, 10.0, 20.0, 40.0)}
SEARCHED = {
    # the geometric controller's own gains, with the observer at its tuned rates
    "geometric-ndob:tuned": ("kx_per_mass", "kv_per_mass", "kR", "kOmega"),
    "pid": ("position_kp", "position_kd", "position_ki", "attitude_kp", "rate_kp", "rate_ki",
            "rate_kd"),
    "smc": ("position_lambda", "position_boundary", "attitude_lambda", "attitude_eta",
            "attitude_boundary"),
}
# Where the descent starts: the hand-set gains the baselines shipped with before tuning, so
# a rerun reproduces the shipped defaults (PID_GAINS, SMC_GAINS) rather than starting there.
START = {
    "geometric-ndob:tuned": dict(PAPER_GAINS),  # Lee 2010's, which the paper flies
    "pid": {**PID_GAINS, "position_kp": 16.0, "position_kd": 6.0, "position_ki": 6.0,
            "attitude_kp": 10.0, "rate_kp": 25.0, "rate_ki": 20.0, "rate_kd": 0.3},
    "smc": {**SMC_GAINS, "position_lambda": 2.8, "position_boundary": 0.35,
            "attitude_lambda": 8.0, "attitude_eta": 40.0, "attitude_boundary": 1.0},
}


def score(build: Callable[[], Controller], scenarios: tuple[str, ...] = TUNING_SCENARIOS,
          seeds: tuple[int, ...] = TUNING_SEEDS) -> dict[str, float]:
    """Per scenario, the mean settled RMS position error over ``seeds`` (lost flights count
    as ``LOST_FLIGHT``), and their mean as ``objective``."""
    result = {}
    for name in scenarios:
        base, options = TUNING_VARIANTS.get(name, (name, {}))
        flights = fly_policy(Policy("candidate", build()), make_scenario(base, **options),
                             list(seeds))
        values = [LOST_FLIGHT if m["crashed"] else m["rms_position_settled"]
                  for m in map(flight_metrics, flights)]
        result[name] = float(np.mean(values))
    result["objective"] = float(np.mean(list(result.values())))
    return result


def coordinate_descent(controller: str, log: Callable[[str], None] = print,
                       **score_options: Any) -> tuple[dict[str, float], list[dict]]:
    """The gains of ``controller`` ("pid", "smc", or "geometric-ndob:tuned" for the geometric
    controller's own gains) that minimise the objective."""
    gains = dict(START[controller])
    history = []

    def trial(candidate: dict[str, float]) -> float:
        scores = score(lambda: make_controller(controller, "paper", **candidate),
                       **score_options)
        history.append({"gains": dict(candidate), **scores})
        return scores["objective"]

    best = trial(gains)
    log(f"{controller}: the hand-set start scores {best:.4f} m")
    for sweep in range(PASSES):
        for name in SEARCHED[controller]:
            start = gains[name]
            for factor in FACTORS:
                candidate = {**gains, name: round(start * factor, 6)}
                value = trial(candidate)
                if value < best:
                    best, gains = value, candidate
            log(f"  pass {sweep + 1}, {name}: {gains[name]:.4g} (objective {best:.4f} m)")
    return gains, history


def observer_grid(log: Callable[[str], None] = print,
                  **score_options: Any) -> tuple[dict[str, float], list[dict]]:
    """The NDOB decay rates (translational, rotational) that minimise the objective."""
    vehicle = get_vehicle("paper")
    history = []
    for translational, rotational in itertools.product(*OBSERVER_RATES.values()):
        rates = {"translational_rate": translational, "rotational_rate": rotational}
        scores = score(lambda rates=rates: GeometricController(
            observer=NonlinearDisturbanceObserver.from_rates(vehicle=vehicle, **rates)),
            **score_options)
        history.append({"gains": rates, **scores})
        log(f"  rates {translational:g} / {rotational:g} /s: {scores['objective']:.4f} m")
    best = min(trial["objective"] for trial in history)
    near = [trial for trial in history if trial["objective"] <= best * (1 + TIE_TOLERANCE)]
    chosen = min(near, key=lambda trial: (trial["gains"]["translational_rate"],
                                          trial["gains"]["rotational_rate"]))
    log(f"geometric-ndob: best objective {best:.4f} m; slowest rates within "
        f"{TIE_TOLERANCE:.0%}: {chosen['gains']} ({chosen['objective']:.4f} m)")
    return chosen["gains"], history


def main(controllers: list[str], out: Path) -> int:
    start = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    report: dict[str, Any] = {"seeds": list(TUNING_SEEDS), "scenarios": list(TUNING_SCENARIOS)}
    for controller in controllers:
        if controller == "geometric-ndob":
            winner, history = observer_grid()
        elif controller in SEARCHED:
            winner, history = coordinate_descent(controller)
        else:
            raise ValueError(f"quad-dob tune tunes pid, smc, geometric-ndob (its observer "
                             f"rates) and geometric-ndob:tuned (the controller's gains, the "
                             f"observer at its tuned rates), got {controller!r}")
        report[controller] = {"winner": winner, "history": history}
        print(f"{controller}: {json.dumps(winner)}")
    (out / "tuning.json").write_text(json.dumps(report, indent=1) + "\n")
    print(f"wrote {out / 'tuning.json'} in {time.perf_counter() - start:.0f} s")
    return 0
