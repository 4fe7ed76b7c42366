"""The guide's example mechanism (docs/design.md, "Add a mechanism to the vehicle loop"):
each rotor's true thrust coefficient off the nominal by a factor drawn per episode,
``LoopOptions.rotor_thrust_mismatch``. Off in v1-v3; on, it acts inside the compiled tick
through ``dynamics.rotors.true_thrust_scales``."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_env.dynamics.rotors import RotorModel, rotor_wrench, true_thrust_scales
from quad_dob_env.loop_options import LoopOptions
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario

MISMATCH = 0.1


def _factors(env: gym.Env) -> np.ndarray:
    sampled = env.unwrapped.core.sampled[0]
    return np.array([sampled[f"rotor_{k}_thrust_factor"] for k in range(4)])


@pytest.mark.parametrize("benchmark", ["v1", "v2", "v3"])
def test_the_benchmarks_fly_without_it(benchmark):
    assert LoopOptions.preset(benchmark).rotor_thrust_mismatch == 0.0
    scenario = make_scenario("hover-calm", benchmark=benchmark)
    env = gym.make("QuadDOB/Hover-v1", scenario=scenario)
    env.reset(seed=0)
    np.testing.assert_array_equal(env.unwrapped.core.loop.rotor_thrust_factor, 1.0)


def test_each_episode_draws_its_own_factors_with_a_mean_of_one():
    env = gym.make("QuadDOB/Hover-v3", scenario_options={"rotor_thrust_mismatch": MISMATCH})
    env.reset(seed=3)
    first = _factors(env)
    env.reset(seed=3)
    np.testing.assert_array_equal(_factors(env), first)  # seeded
    env.reset(seed=4)
    second = _factors(env)
    assert not np.allclose(first, second)
    for factors in (first, second):
        assert factors.mean() == pytest.approx(1.0, abs=1e-15)
        # 1 + δ in [0.9, 1.1], rescaled by 4 / sum: within 0.9 / 1.1 and 1.1 / 0.9
        assert np.all((factors > 0.9 / 1.1) & (factors < 1.1 / 0.9))
    np.testing.assert_array_equal(env.unwrapped.core.loop.draws.rotor_thrust_factor[0],
                                  second)


def test_switching_it_on_changes_no_other_draw():
    off = gym.make("QuadDOB/Hover-v3")
    on = gym.make("QuadDOB/Hover-v3", scenario_options={"rotor_thrust_mismatch": MISMATCH})
    _, info_off = off.reset(seed=7)
    _, info_on = on.reset(seed=7)
    shared = {key: value for key, value in info_on["sampled"].items()
              if not key.startswith("rotor_")}
    assert shared == info_off["sampled"]
    np.testing.assert_array_equal(on.unwrapped.core.state.position,
                                  off.unwrapped.core.state.position)


def test_the_rotors_wrench_carries_each_factor():
    # an oracle from the equations: at equal speeds in still air, rotor k lifts
    # s f_k k_F ω² at its hub p_k, so the moment is Σ p_k × (0, 0, T_k) plus the drag
    # torques c_τ spin_k T_k; a factor on the wrong rotor moves the moment
    vehicle = get_vehicle("neural-fly")
    rotors = RotorModel.of(vehicle, True, False, True)
    factors = np.array([[1.08, 0.95, 1.01, 0.96]])
    draws = type("Draws", (), {})()
    draws.thrust_scale, draws.rotor_thrust_factor = np.array([1.02]), factors
    scales = true_thrust_scales.py_func(0, draws)
    omega = 600.0
    force, moment = rotor_wrench((omega,) * 4, (0.0, 0.0, 0.0), tuple(np.eye(3).reshape(9)),
                                 (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), scales, rotors)
    thrusts = 1.02 * factors[0] * rotors.thrust_coefficient * omega**2
    expected = sum(np.cross(rotors.positions[k], [0.0, 0.0, thrusts[k]])
                   + np.array([0.0, 0.0, rotors.spin[k] * thrusts[k]]) for k in range(4))
    np.testing.assert_allclose(force, [0.0, 0.0, thrusts.sum()], rtol=1e-12)
    np.testing.assert_allclose(moment, expected, rtol=1e-12, atol=1e-12)


def test_it_flies_into_the_true_disturbance():
    # the autopilot's nominal model knows nothing of it: the rotors' moment beyond the
    # nominal shows in the true disturbance torque, and the vehicle rolls or pitches
    on = gym.make("QuadDOB/Hover-v3", scenario_options={"rotor_thrust_mismatch": MISMATCH})
    off = gym.make("QuadDOB/Hover-v3")
    for env in (on, off):
        env.reset(seed=1)
        for _ in range(5):
            _, _, _, _, info = env.step(np.zeros(4, dtype=np.float32))
        env.info = info
    torque_on = np.abs(on.info["disturbance_torque"][:2]).max()
    torque_off = np.abs(off.info["disturbance_torque"][:2]).max()
    assert torque_on > 10 * max(torque_off, 1e-6)


def test_it_needs_the_rotors_own_model():
    with pytest.raises(ValueError, match="rotor_thrust_mismatch acts on the rotors' own model"):
        make_scenario("hover-calm", rotor_thrust_mismatch=MISMATCH)
    with pytest.raises(ValueError, match=r"in \[0, 0.5\)"):
        LoopOptions(rotor_thrust_mismatch=0.7)


def test_no_mechanism_moves_anothers_draw():
    # each per-episode draw comes from a stream named for it (rng.named_stream), not the
    # n-th child spawned: switching the mismatch on moves none of the ranges' draws
    ranges = {"unmodelled_pose_latency": (0.0, 0.02), "imu_vibration_scale": (0.5, 1.5),
              "motor_time_constant_scale": (0.8, 1.2)}
    alone = gym.make("QuadDOB/Hover-v3", scenario_options=ranges)
    both = gym.make("QuadDOB/Hover-v3",
                    scenario_options={**ranges, "rotor_thrust_mismatch": MISMATCH})
    for seed in (9, 10):
        _, drawn_alone = alone.reset(seed=seed)
        _, drawn_both = both.reset(seed=seed)
        for key in ranges:
            assert drawn_both["sampled"][key] == drawn_alone["sampled"][key], key
