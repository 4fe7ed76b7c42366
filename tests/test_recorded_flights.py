"""Flights kept bit for bit across the house's redesign (issue 41).

``tests/data/recorded_flights.json`` holds final states printed by this file's ``record``
mode on the tree before the redesign (commit 666bb22): every classical controller and both
shipped residuals in Benchmarks v1, v2 and v3, and every registered id and residual option
stepped with seeded actions. The redesign moved code and renamed things; no flight may
change. The project's VM gave these bit for bit (same CPU, numpy, numba and torch builds);
the test allows 1e-9 (1e-6 where a torch policy flies: its float32 matrix products round
by the CPU's vector width, and a chattering policy grows that rounding over a flight: on an
AMD EPYC machine `residual:v1` in v3's loop ended 3.1e-8 m from the record, beyond the 1e-8
first allowed) so that another CPU's rounding cannot fail it, far below any change of an
equation.

Re-record only for a change meant to move flights: ``python tests/test_recorded_flights.py``.
A new id is recorded without touching the others: ``python tests/test_recorded_flights.py
--new-ids`` (the -v4 ids, 2026-12-06); one benchmark's ids again, for a change meant to
move that benchmark's flights alone, ``--ids-again -v4`` (issue 55: v4's own gain sets
replaced the v3 sets its ids' bases flew, 2026-12-07).
One such change so far (issue 43): ``residual:v2`` flown in v1 and v3 flew v2's loop, its
training config's benchmark rebuilding the scenario; its eight flights there were recorded
again after the fix (their final states moved by 3-105 mm), every other entry is as before.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_composition import ResidualVectorEnv
from quad_dob_env.envs import QuadrotorVectorEnv
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.policies import fly_policy, make_policy

RECORDS = Path(__file__).parent / "data" / "recorded_flights.json"
BENCHMARKS = ("v1", "v2", "v3")
SCENARIOS = ("dryden-helix-gusts", "figure8-wind-8.5", "ground-effect-landing",
             "hover-step-force")
POLICIES = ("geometric-ndob:tuned", "geometric-integral", "indi", "l1", "pid", "smc",
            "residual:v1", "residual:v2")
SEEDS = [11, 12]
DURATION = 2.0  # [s]: long enough for every loop's lags and the wind's gusts to act

# residual options stepped through the vector env with seeded actions, one case each
RESIDUAL_CASES = {
    "default": {},
    "shipped-v2": {"residual_mode": "acceleration", "acceleration_scale": 3.0,
                   "vertical_floor": 0.5, "moment_scale": 0.3, "residual_effort_weight": 0.1,
                   "authority_gate": 0.02, "reward_position_scale": 0.1},
    "gate-tilt": {"authority_gate": 0.05, "authority_signal": "wind",
                  "residual_rate_weight": 0.05, "thrust_scale": 0.2},
}
BASES = ("geometric-ndob:tuned", "pid")
ACCELERATION_BASES = ("geometric-ndob:tuned", "geometric")  # the mode's bases


def bases_for(case: str) -> tuple[str, ...]:
    return (ACCELERATION_BASES if RESIDUAL_CASES[case].get("residual_mode") == "acceleration"
            else BASES)
STEPS = 150


def _flight_key(benchmark: str, scenario: str, policy: str) -> str:
    return f"{benchmark}|{scenario}|{policy}"


def fly_recorded(benchmark: str, scenario: str, policy: str) -> list[list[float]]:
    """Each seed's final position and velocity, then its record's length."""
    flights = fly_policy(make_policy(policy),
                         make_scenario(scenario, benchmark=benchmark, duration=DURATION), SEEDS)
    return [[*flight.position[-1].tolist(), *flight.velocity[-1].tolist(),
             float(len(flight.position))] for flight in flights]


def _actions(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, (n, 4)).astype(np.float32)


def step_vector(benchmark: str, case: str, base: str) -> list[float]:
    """The final observation of 2 vehicles over STEPS seeded steps (autoresets included),
    then the summed reward and the ends counted."""
    env = ResidualVectorEnv(2, "random-tracks", benchmark=benchmark, base_controller=base,
                            **RESIDUAL_CASES[case])
    obs, _ = env.reset(seed=21)
    rng = np.random.default_rng(5)
    total, ends = 0.0, 0
    for _ in range(STEPS):
        obs, reward, terminated, truncated, _ = env.step(0.5 * _actions(rng, 2))
        total += float(reward.sum())
        ends += int((terminated | truncated).sum())
    return [*obs.astype(np.float64).ravel().tolist(), total, float(ends)]


def step_direct(benchmark: str) -> list[float]:
    env = QuadrotorVectorEnv(2, "dryden-helix-gusts", benchmark=benchmark)
    obs, _ = env.reset(seed=21)
    rng = np.random.default_rng(5)
    total = 0.0
    for _ in range(STEPS):
        obs, reward, *_ = env.step(0.05 * _actions(rng, 2))
        total += float(reward.sum())
    return [*obs.astype(np.float64).ravel().tolist(), total]


def step_id(env_id: str) -> list[float]:
    """A single env made by its id, stepped with seeded actions over its autoresets."""
    env = gym.make(env_id)
    obs, _ = env.reset(seed=33)
    rng = np.random.default_rng(9)
    total = 0.0
    scale = 0.05 if "Residual" not in env_id else 0.5
    for _ in range(STEPS):
        obs, reward, terminated, truncated, _ = env.step(scale * _actions(rng, 1)[0])
        total += float(reward)
        if terminated or truncated:
            obs, _ = env.reset()
    env.close()
    return [*np.asarray(obs, dtype=np.float64).tolist(), total]


QUAD_IDS = sorted(key for key in gym.registry if key.startswith("QuadDOB/"))


def record() -> dict:
    records: dict = {"flights": {}, "vector": {}, "direct": {}, "ids": {}}
    for benchmark in BENCHMARKS:
        for scenario in SCENARIOS:
            for policy in POLICIES:
                records["flights"][_flight_key(benchmark, scenario, policy)] = fly_recorded(
                    benchmark, scenario, policy)
        for case in RESIDUAL_CASES:
            for base in bases_for(case):
                records["vector"][f"{benchmark}|{case}|{base}"] = step_vector(benchmark, case,
                                                                              base)
        records["direct"][benchmark] = step_direct(benchmark)
    for env_id in QUAD_IDS:
        records["ids"][env_id] = step_id(env_id)
    return records


def _recorded() -> dict:
    return json.loads(RECORDS.read_text())


def _close(flown, recorded, tolerance: float) -> None:
    np.testing.assert_allclose(np.asarray(flown), np.asarray(recorded), rtol=0, atol=tolerance)


FLIGHT_CASES = [(b, s, p) for b in BENCHMARKS for s in SCENARIOS for p in POLICIES]
# one flight per benchmark stays in the fast loop; the rest run in `make test`
FAST_FLIGHTS = {("v1", "dryden-helix-gusts", "geometric-ndob:tuned"),
                ("v2", "figure8-wind-8.5", "residual:v2"),
                ("v3", "ground-effect-landing", "indi")}


@pytest.mark.parametrize(("benchmark", "scenario", "policy"), [
    case if case in FAST_FLIGHTS else pytest.param(*case, marks=pytest.mark.slow)
    for case in FLIGHT_CASES])
def test_flights_are_kept_bit_for_bit(benchmark, scenario, policy):
    recorded = _recorded()["flights"][_flight_key(benchmark, scenario, policy)]
    tolerance = 1e-6 if policy.startswith("residual") else 1e-9
    _close(fly_recorded(benchmark, scenario, policy), recorded, tolerance)


@pytest.mark.parametrize("benchmark", BENCHMARKS)
@pytest.mark.parametrize("case", [
    case if case == "shipped-v2" else pytest.param(case, marks=pytest.mark.slow)
    for case in RESIDUAL_CASES])
def test_residual_options_step_bit_for_bit(benchmark, case):
    recorded = _recorded()["vector"]
    for base in bases_for(case):
        _close(step_vector(benchmark, case, base), recorded[f"{benchmark}|{case}|{base}"],
               1e-6)  # float32 observations: 1e-6 is below their resolution at these sizes


@pytest.mark.parametrize("benchmark", BENCHMARKS)
def test_direct_control_steps_bit_for_bit(benchmark):
    _close(step_direct(benchmark), _recorded()["direct"][benchmark], 1e-6)


@pytest.mark.parametrize("env_id", QUAD_IDS)
def test_every_id_steps_bit_for_bit(env_id):
    recorded = _recorded()["ids"]
    assert env_id in recorded, f"{env_id} is new: record it (this file's record mode)"
    _close(step_id(env_id), recorded[env_id], 1e-6)


def record_ids(again: str | None = None) -> dict:
    """The records as they are, with each registered id that has none stepped and added;
    ``again``: the ids ending in it stepped and recorded again too."""
    records = _recorded()
    for env_id in QUAD_IDS:
        if env_id not in records["ids"] or (again and env_id.endswith(again)):
            records["ids"][env_id] = step_id(env_id)
            print(f"recorded {env_id}", file=sys.stderr)
    return records


if __name__ == "__main__":
    RECORDS.parent.mkdir(exist_ok=True)
    arguments = sys.argv[1:]
    if "--new-ids" in arguments:
        records = record_ids()
    elif "--ids-again" in arguments:  # e.g. --ids-again -v4
        records = record_ids(arguments[arguments.index("--ids-again") + 1])
    else:
        records = record()
    RECORDS.write_text(json.dumps(records, indent=1) + "\n")
    print(f"wrote {RECORDS}", file=sys.stderr)
