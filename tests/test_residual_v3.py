"""Issue 42's pieces for residual RL in Benchmark v3's loop: v3's uncertain quantities drawn
per training group, and the scenario each group then flies."""

import itertools

import numpy as np
import pytest

from quad_dob_env.benchmark import v3_loop
from quad_dob_env.benchmark_v3 import REAL_LOOPS
from quad_dob_env.params import get_vehicle
from quad_dob_training.rl.vec_env import QuadrotorSB3VecEnv, draw_loops, loop_scenario_options

V3_SPEC = {"groups": 4, "vehicle": ["paper", "neural-fly"],
           "unmodelled_pose_latency": [0.0, 0.01], "thrust_model_factor": [0.3, 0.5],
           "accelerometer_vibration": [0.0, 30.0], "hover_throttle": [0.444, 0.504],
           "hover_throttle_drift": [0.000069, 0.00033]}


def test_v3_quantities_are_stratified_over_the_groups_and_leave_older_draws_alone():
    loops = draw_loops(V3_SPEC, 3, 0.01)
    for key in ("unmodelled_pose_latency", "thrust_model_factor", "accelerometer_vibration"):
        low, high = V3_SPEC[key]
        slices = sorted(int((loop[key] - low) / (high - low) * 4) for loop in loops)
        assert slices == [0, 1, 2, 3], key  # one draw in each quarter of the range
    # the battery's ranges are split: each group one slice, together the whole
    for key in ("hover_throttle", "hover_throttle_drift"):
        pieces = sorted(tuple(loop[key]) for loop in loops)
        assert pieces[0][0] == pytest.approx(V3_SPEC[key][0])
        assert pieces[-1][1] == pytest.approx(V3_SPEC[key][1])
        assert all(a[1] == pytest.approx(b[0]) for a, b in itertools.pairwise(pieces))
    older = {k: v for k, v in V3_SPEC.items() if k in ("groups", "vehicle")}
    assert [{k: v for k, v in loop.items() if k in draw_loops(older, 3, 0.01)[0]}
            for loop in loops] == draw_loops(older, 3, 0.01)
    with pytest.raises(ValueError, match="thrust_model_factor must be a range"):
        draw_loops({"thrust_model_factor": [0.5, 0.3]}, 0, 0.01)


def test_a_drawn_loop_becomes_the_vehicles_v3_loop_with_those_values():
    loop = {"vehicle": "neural-fly", "thrust_model_factor": 0.33, "accelerometer_vibration": 7.5,
            "hover_throttle": [0.45, 0.46], "unmodelled_pose_latency": 0.004}
    options = loop_scenario_options(loop, "neural-fly")
    real = REAL_LOOPS["neural-fly"]
    assert options["throttle_map"].thrust_model_factor == 0.33
    assert options["throttle_map"].hover_throttle == (0.45, 0.46)
    assert options["throttle_map"].hover_throttle_drift == real.throttle_map.hover_throttle_drift
    nominal = v3_loop(get_vehicle("neural-fly"), "x")["imu_vibration"][1]
    # half the nominal raw vibration leaves half the filtered level
    assert options["imu_vibration"][1] == pytest.approx(nominal * 7.5 / 15.0)
    assert options["unmodelled_pose_latency"] == 0.004 and options["vehicle"] == "neural-fly"
    with pytest.raises(ValueError, match="need a vehicle with a v3 loop"):
        loop_scenario_options({"thrust_model_factor": 0.4}, "crazyflie")


def test_the_v3_recipes_groups_fly_what_was_drawn():
    env = QuadrotorSB3VecEnv(8, "random-tracks", seed=0, benchmark="v3",
                             base_controller="geometric-ndob:tuned", residual_mode="acceleration",
                             loop_randomization=V3_SPEC)
    for loop, venv in zip(env.loops, env.vector_envs, strict=True):
        flown = venv.scenario
        assert flown.loop.benchmark == "v3" and flown.vehicle.name == loop["vehicle"]
        assert flown.loop.throttle_map.thrust_model_factor == loop["thrust_model_factor"]
        assert flown.loop.unmodelled_pose_latency == loop["unmodelled_pose_latency"]
    env.reset()
    env.step_async(np.zeros((8, 4), np.float32))
    _, rewards, _, _ = env.step_wait()
    assert np.all(np.isfinite(rewards))
