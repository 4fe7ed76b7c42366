"""``benchmark=``: one scenario option for the whole loop (Benchmark v2, part 3)."""

from __future__ import annotations

import numpy as np
import pytest

from quad_dob_baselines import make_controller
from quad_dob_env.benchmark import LOOP_FIELDS, V2_INNER_RATE
from quad_dob_env.scenarios import list_scenarios, make_scenario
from quad_dob_env.sensing.models import SENSING_PRESETS
from quad_dob_training.rollout import fly

ROTOR_SCENARIOS = [name for name in list_scenarios() if not name.startswith("paper-")]


@pytest.mark.parametrize("name", list_scenarios())
def test_benchmark_v1_is_the_scenario_as_it_was(name):
    as_was, v1 = make_scenario(name), make_scenario(name, benchmark="v1")
    for key in (*LOOP_FIELDS, "motor_lag", "actuation", "dt", "substeps", "duration"):
        assert getattr(v1, key) == getattr(as_was, key), key


def test_benchmark_v1_flies_v1_bit_for_bit():
    flights = [fly(make_controller("geometric-ndob:tuned"), make_scenario(
        "dryden-helix-gusts", **options), seed=9001)[0] for options in ({}, {"benchmark": "v1"})]
    np.testing.assert_array_equal(flights[0].position, flights[1].position)


@pytest.mark.parametrize("name", ["hover-calm", "dryden-helix-gusts", "takeoff-landing-wind",
                                  "figure8-wind-8.5"])
def test_benchmark_v2_sets_every_factor_of_parts_one_and_two(name):
    scenario = make_scenario(name, benchmark="v2")
    assert scenario.sensing == SENSING_PRESETS["mocap"]
    assert scenario.inner_rate == V2_INNER_RATE and scenario.inner_ticks == 2
    assert scenario.speed_motors and scenario.thrust_uncertainty
    assert scenario.rotor_aerodynamics and scenario.drag


def test_a_factor_given_keeps_its_value_so_each_can_be_switched_off_in_turn():
    scenario = make_scenario("dryden-helix-gusts", benchmark="v2", speed_motors=False,
                             sensing="ideal", inner_rate=0)
    assert not scenario.speed_motors and scenario.sensing is None
    assert scenario.inner_rate is None and scenario.inner_ticks == 1
    assert scenario.thrust_uncertainty and scenario.rotor_aerodynamics
    # and a v1 scenario with one factor on is v1 but for it
    one = make_scenario("dryden-helix-gusts", rotor_aerodynamics=True)
    assert one.rotor_aerodynamics and not one.speed_motors and one.sensing is None


def test_changing_the_benchmark_resets_the_loop_and_comes_back():
    calm = make_scenario("hover-calm")
    there = calm.with_changes(benchmark="v2")
    assert there.speed_motors and there.drag and there.sensing is not None
    back = there.with_changes(benchmark="v1")
    assert all(getattr(back, key) == getattr(calm, key) for key in LOOP_FIELDS)
    # a field the scenario's builder gave stays: the wind helix keeps its drag
    helix = make_scenario("dryden-helix-gusts", benchmark="v2").with_changes(benchmark="v1")
    assert helix.drag and not helix.speed_motors


def test_the_inner_rate_is_the_first_multiple_of_the_control_rate_at_200_hz():
    assert make_scenario("hover-calm", benchmark="v2", dt=0.02).inner_ticks == 4
    assert make_scenario("hover-calm", benchmark="v2", dt=0.003).inner_rate == pytest.approx(
        1 / 0.003)
    assert make_scenario("hover-calm", benchmark="v2", dt=0.004).inner_ticks == 1


def test_the_papers_wrench_scenarios_are_v1_only_and_names_are_checked():
    with pytest.raises(ValueError, match="paper-\\* scenarios are v1-only"):
        make_scenario("paper-II", benchmark="v2")
    with pytest.raises(ValueError, match="unknown benchmark 'v3'; valid: v1, v2"):
        make_scenario("hover-calm", benchmark="v3")


def test_the_v2_ids_fly_benchmark_v2_and_the_v1_ids_stay_v1():
    import gymnasium as gym

    import quad_dob_env

    assert set(quad_dob_env.ENV_IDS_V2) == {"QuadDOB/Hover-v2", "QuadDOB/HoverResidual-v2",
                                            "QuadDOB/TrackResidual-v2",
                                            "QuadDOB/TracksResidual-v2"}
    for v2_id in ("QuadDOB/Hover-v2", "QuadDOB/TrackResidual-v2"):
        v1_id = v2_id.replace("-v2", "-v1")
        v2 = gym.make(v2_id).unwrapped.core.scenario
        v1 = gym.make(v1_id).unwrapped.core.scenario
        assert v2.name == v1.name and v2.benchmark == "v2" and v1.benchmark == "v1"
        assert v2.speed_motors and v2.inner_rate == V2_INNER_RATE and not v1.speed_motors
    # an option given with the id wins over the benchmark's, and the vector face agrees
    off = gym.make("QuadDOB/Hover-v2", scenario_options={"speed_motors": False})
    assert off.unwrapped.core.scenario.benchmark == "v2"
    assert not off.unwrapped.core.scenario.speed_motors
    vector = gym.make_vec("QuadDOB/TrackResidual-v2", num_envs=2,
                          vectorization_mode="vector_entry_point")
    assert vector.unwrapped.core.scenario.benchmark == "v2"
    vector.reset(seed=0)
    observation, *_ = vector.step(np.zeros((2, 4), np.float32))
    assert np.all(np.isfinite(observation))
