"""``LoopOptions``: the vehicle loop as one record (issue 52), resolved as the scenario
fields it replaced were, taken flat wherever they were, and each env's scenario built once."""

from __future__ import annotations

import ast
import dataclasses
import json
import math
from pathlib import Path

import gymnasium as gym
import pytest

import quad_dob_env
from quad_dob_env.benchmark import LOOP_FIELDS, V2_INNER_RATE
from quad_dob_env.benchmark_v3 import REAL_LOOPS
from quad_dob_env.benchmark_v4 import V4_LOOPS
from quad_dob_env.loop_options import (
    DEFAULT_LOOP_OPTIONS,
    LOOP_KEYS,
    OPTION_NAMES,
    LoopOptions,
    split_loop_keys,
)
from quad_dob_env.params import VEHICLES, get_vehicle
from quad_dob_env.scenario import FORMER_FIELDS, Scenario
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.sensing.models import SENSING_PRESETS
from quad_dob_env.trajectories import Hover
from quad_dob_env.variation import SensorNoise

RESOLUTIONS = Path(__file__).parent / "data" / "loop_resolutions.json"
# the 18 scenario fields the record replaced: its 17 options and sensing's ``sensors``
MOVED = (*FORMER_FIELDS, "sensors")


def _plain(value: object) -> str:
    """A resolved value as ``loop_resolutions.json`` records it."""
    for name, preset in SENSING_PRESETS.items():
        if preset is not None and value == preset:
            return f"preset:{name}"
    return repr(value)


def _same_record(got: str, recorded: str) -> bool:
    """Equal reprs, or (computed vibration levels) the same pair of numbers to 1e-12."""
    if got == recorded:
        return True
    try:
        got_value, recorded_value = ast.literal_eval(got), ast.literal_eval(recorded)
    except (ValueError, SyntaxError):
        return False
    return (isinstance(got_value, tuple) and len(got_value) == len(recorded_value)
            and all(math.isclose(a, b, rel_tol=1e-12)
                    for a, b in zip(got_value, recorded_value, strict=True)))


def test_the_record_holds_the_loop_and_the_scenario_holds_the_record():
    assert set(LOOP_FIELDS) | {"benchmark", "motor_lag", "motor_time_constant_scale",
                               "extra_latency", "unmodelled_pose_latency",
                               "imu_vibration_scale", "rotor_thrust_mismatch",
                               "estimator_wrench"} == set(OPTION_NAMES)
    assert LOOP_KEYS == (*OPTION_NAMES, "sensors")
    fields = {f.name for f in dataclasses.fields(Scenario)}
    assert "loop" in fields and not fields & set(MOVED)
    # 41 fields before (18 of them the loop's, and ``loop_given``), 23 now
    assert len(fields) == 23


def test_resolution_is_as_the_scenario_fields_resolved_before_the_record():
    # every case of loop_resolutions.json, recorded on the tree before LoopOptions
    cases = json.loads(RESOLUTIONS.read_text())["cases"]
    for case in cases:
        name, options = case["scenario"], case["options"]
        if "refused" in case:
            with pytest.raises(ValueError) as refusal:
                make_scenario(name, **options)
            assert str(refusal.value) == case["refused"], (name, options)
            continue
        loop = make_scenario(name, **options).loop
        for key, recorded in case["loop"].items():
            assert _same_record(_plain(getattr(loop, key)), recorded), (name, options, key)
        sensors = loop.sensing if isinstance(loop.sensing, SensorNoise) else None
        assert _plain(sensors) == case["sensors"], (name, options)


@pytest.mark.parametrize("vehicle", ["paper", "neural-fly"])
def test_each_benchmarks_preset_is_its_loop(vehicle):
    # v3's fields off, and v4's: the estimators told the rotors' output, the preset's drag,
    # no tones
    off = {"motor_time_constants": None, "throttle_map": None, "model_tolerance": None,
           "gyro_cutoff": None, "imu_vibration": None, "pose_latency_on_ticks": False,
           "estimator_wrench": "applied", "airframe_drag": None, "imu_vibration_tones": None}
    v1 = LoopOptions.preset("v1", vehicle)
    assert v1 == dataclasses.replace(DEFAULT_LOOP_OPTIONS, speed_motors=False,
                                     thrust_uncertainty=False, rotor_aerodynamics=False,
                                     drag=False, **off)
    v2 = LoopOptions.preset("v2", vehicle)
    assert v2 == LoopOptions(benchmark="v2", sensing=SENSING_PRESETS["mocap"],
                             inner_rate=V2_INNER_RATE, speed_motors=True,
                             thrust_uncertainty=True, rotor_aerodynamics=True, drag=True, **off)
    assert LoopOptions.preset("v2", vehicle, dt=0.003).inner_rate == math.ceil(
        V2_INNER_RATE * 0.003) / 0.003
    real, params = REAL_LOOPS[vehicle], VEHICLES[vehicle]
    rotor_frequency = math.sqrt(params.hover_thrust / 4 / params.thrust_coefficient) / (
        2 * math.pi)
    filtered = real.accelerometer_vibration / math.sqrt(
        1 + (rotor_frequency / real.accelerometer_cutoff) ** 4)
    v3 = LoopOptions.preset("v3", vehicle)
    assert v3.imu_vibration == pytest.approx((real.gyroscope_vibration, filtered), rel=1e-12)
    assert dataclasses.replace(v3, imu_vibration=None) == LoopOptions(
        benchmark="v3", sensing=SENSING_PRESETS["mocap"], inner_rate=real.inner_rate,
        speed_motors=True, thrust_uncertainty=False, rotor_aerodynamics=True, drag=True,
        motor_time_constants=real.motor_time_constants, throttle_map=real.throttle_map,
        model_tolerance=real.model_tolerance, gyro_cutoff=real.gyro_cutoff,
        pose_latency_on_ticks=True, estimator_wrench="applied")
    # a scenario flown in a benchmark flies its preset, but for what its builder gives
    assert make_scenario("hover-calm", benchmark="v3", vehicle=vehicle).loop == v3
    # v4: v3's loop with its own five fields, the white vibration replaced by tones
    own = V4_LOOPS[vehicle]
    assert LoopOptions.preset("v4", vehicle) == dataclasses.replace(
        v3, benchmark="v4", imu_vibration=None, throttle_map=own.throttle_map,
        estimator_wrench="commanded", airframe_drag=own.airframe_drag,
        imu_vibration_tones=own.vibration)


def test_flat_keys_split_into_the_record_and_the_rest_stay():
    keys = {"inner_rate": 400.0, "benchmark": "v2", "dt": 0.01, "wind": "light",
            "sensors": {"position_std": 0.01}}
    loop = split_loop_keys(keys)
    assert keys == {"dt": 0.01, "wind": "light"}
    assert loop == LoopOptions(benchmark="v2", inner_rate=400.0,
                               sensing=SensorNoise(position_std=0.01))
    # laid over a record: its other options kept
    over = split_loop_keys({"speed_motors": False}, LoopOptions(benchmark="v3", motor_lag=True))
    assert over == LoopOptions(benchmark="v3", motor_lag=True, speed_motors=False)
    assert LoopOptions.from_keys(over.keys()) == over
    # ``sensors`` and a sensing that differs is two sensings
    with pytest.raises(ValueError, match=r"sensors is the sensing=SensorNoise"):
        split_loop_keys({"sensing": "mocap", "sensors": SensorNoise(position_std=0.01)})
    with pytest.raises(ValueError, match="loop must be a LoopOptions"):
        split_loop_keys({}, {"inner_rate": 200.0})


def test_the_flat_keys_work_wherever_they_did():
    # (a scenario's trajectory compares by identity: the loops are compared)
    by_record = make_scenario("hover-calm", loop=LoopOptions(benchmark="v3", inner_rate=400.0))
    assert by_record.loop.inner_rate == 400.0 and by_record.loop.benchmark == "v3"
    assert make_scenario("hover-calm", benchmark="v3", inner_rate=400.0).loop == by_record.loop
    assert make_scenario("hover-calm").with_changes(benchmark="v3",
                                                    inner_rate=400.0).loop == by_record.loop
    env = gym.make("QuadDOB/Hover-v1", scenario_options={"benchmark": "v3",
                                                         "inner_rate": 400.0})
    assert env.unwrapped.core.scenario.loop == by_record.loop
    env = gym.make("QuadDOB/Hover-v3", scenario_options={"inner_rate": 400.0})
    assert env.unwrapped.core.scenario.loop == by_record.loop
    # made directly, flat or as the record
    hover = Hover((0.0, 0.0, 1.0))
    flat = Scenario(name="hover", vehicle="paper", trajectory=hover, duration=1.0,
                    inner_rate=200.0, speed_motors=True, motor_lag=True)
    record = Scenario(name="hover", vehicle="paper", trajectory=hover, duration=1.0,
                      loop=LoopOptions(inner_rate=200.0, speed_motors=True, motor_lag=True))
    assert flat == record and flat.inner_ticks == 2
    with pytest.raises(ValueError, match=r"Scenario.loop must be a LoopOptions .* flat keys"):
        Scenario(name="hover", vehicle="paper", trajectory=Hover((0.0, 0.0, 1.0)),
                 duration=1.0, loop={"inner_rate": 200.0})


def test_an_unknown_key_is_named_with_the_valid_ones():
    with pytest.raises(ValueError, match=r"unknown loop option 'inner_rat'; valid: benchmark, "
                                         r".*\(did you mean 'inner_rate'\?\)"):
        LoopOptions.from_keys({"inner_rat": 200.0})
    with pytest.raises(ValueError, match=r"unknown loop option 'spead_motors'.*speed_motors"):
        LoopOptions().with_keys(spead_motors=True)
    with pytest.raises(ValueError, match=r"unknown option for scenario 'hover-calm' "
                                         r"'inner_rat'; valid: .*gyro_cutoff.*sensors"):
        make_scenario("hover-calm", inner_rat=200.0)
    with pytest.raises(ValueError, match=r"unknown Scenario field or loop option 'drgs'.*drag"):
        make_scenario("hover-calm").with_changes(drgs=True)


def test_the_record_checks_its_own_options():
    for options, message in (({"benchmark": None}, "unknown benchmark None"),
                             ({"drag": 1}, "LoopOptions.drag must be True or False"),
                             ({"motor_lag": None}, "LoopOptions.motor_lag must be True"),
                             ({"inner_rate": -100.0}, "LoopOptions.inner_rate must be >= 0"),
                             ({"motor_time_constants": (0.03,)}, "(spin-up, spin-down)"),
                             ({"imu_vibration": (-0.1, 0.0)}, r"imu_vibration\[0\] must be"),
                             ({"throttle_map": {"thrust_model_factor": 0.4}},
                              "ThrottleMap: .*hover_throttle"),
                             ({"model_tolerance": {"masss": 0.1}},
                              "unknown ModelTolerance field 'masss'"),
                             ({"sensing": "mocup"}, "unknown sensing preset 'mocup'"),
                             ({"extra_latency": -0.01}, "extra_latency must be >= 0")):
        with pytest.raises(ValueError, match=message):
            LoopOptions(**options)
    # what needs the vehicle, its actuation or the clock is checked when resolved
    with pytest.raises(ValueError, match="whole multiple of the control rate"):
        LoopOptions(inner_rate=150.0).resolved(get_vehicle("paper"), 0.01)
    with pytest.raises(ValueError, match="paper-\\* scenarios are v1-only"):
        LoopOptions.preset("v2", actuation="wrench")


def test_an_option_given_wins_over_the_benchmark():
    given = LoopOptions(benchmark="v3", gyro_cutoff=40.0, speed_motors=False, sensing="ideal")
    loop = given.resolved(get_vehicle("paper"), 0.01)
    assert loop.gyro_cutoff == 40.0 and not loop.speed_motors and loop.sensing is None
    # and what acts through a part switched off goes with it, as the benchmark resolves it
    assert loop.throttle_map is None and loop.imu_vibration is None
    assert loop.as_given() is given and given.as_given() is given
    assert make_scenario("dryden-helix-gusts", loop=given).loop == loop


def test_a_change_of_benchmark_resolves_the_loop_again():
    v3 = make_scenario("dryden-helix-gusts", benchmark="v3", speed_motors=False)
    v2 = v3.with_changes(benchmark="v2")
    assert v2.loop.benchmark == "v2" and not v2.loop.speed_motors  # given: kept
    assert v2.loop.thrust_uncertainty and v2.loop.inner_rate == V2_INNER_RATE  # v2's own
    assert v2.loop.gyro_cutoff is None and v2.loop.throttle_map is None  # v3's gone
    assert v2.loop == make_scenario("dryden-helix-gusts", benchmark="v2",
                                    speed_motors=False).loop
    back = v2.with_changes(benchmark="v1", speed_motors=None)
    assert back.loop == make_scenario("dryden-helix-gusts").loop
    assert back.loop.as_given() == make_scenario("dryden-helix-gusts").loop.as_given()
    assert back.loop.drag and back.loop.motor_lag  # the builder's own loop stays
    # nothing changed: the scenario itself, not a copy checked again
    assert v2.with_changes(benchmark="v2") is v2


def test_reading_a_moved_field_off_the_scenario_warns_and_names_its_place():
    scenario = make_scenario("hover-calm", benchmark="v2")
    with pytest.warns(DeprecationWarning, match=r"read scenario\.loop\.inner_rate"):
        assert scenario.inner_rate == scenario.loop.inner_rate == V2_INNER_RATE
    with pytest.warns(DeprecationWarning, match=r"read scenario\.loop\.sensing"):
        assert scenario.sensors is None
    for name in MOVED:
        with pytest.warns(DeprecationWarning, match=f"Scenario.{name} is deprecated"):
            getattr(scenario, name)
    # options added to the record since were never Scenario fields: no shim, no warning
    for name in set(OPTION_NAMES) - set(FORMER_FIELDS):
        assert not hasattr(scenario, name), name


# one id of each kind: v1 direct, v3 direct, v3 residual
COUNTED_IDS = ("QuadDOB/Hover-v1", "QuadDOB/Hover-v3", "QuadDOB/HoverResidual-v3")


def _counting_builds(monkeypatch) -> list[str]:
    """Patch ``Scenario.__post_init__`` (the checks, feasibility's the slow one) to record
    each scenario built."""
    built: list[str] = []
    checks = Scenario.__post_init__

    def counted(self: Scenario) -> None:
        built.append(self.name)
        checks(self)

    monkeypatch.setattr(Scenario, "__post_init__", counted)
    return built


@pytest.mark.parametrize("env_id", COUNTED_IDS)
def test_each_env_builds_its_scenario_once(monkeypatch, env_id):
    from quad_dob_training.rl import make_sb3_vec_env

    built = _counting_builds(monkeypatch)
    for make in (lambda: gym.make(env_id),
                 lambda: gym.make_vec(env_id, num_envs=2,
                                      vectorization_mode="vector_entry_point"),
                 lambda: make_sb3_vec_env(env_id, 2)):
        built.clear()
        make().close()
        assert built == [quad_dob_env.ALL_ENV_IDS[env_id]], env_id


def test_a_randomised_training_loop_builds_once_per_group_and_once_for_its_clock(monkeypatch):
    # the groups fly loops of their own (a scenario each); the latencies are drawn on the
    # control step, which one more build of the env's scenario gives
    from quad_dob_training.rl import make_sb3_vec_env

    built = _counting_builds(monkeypatch)
    make_sb3_vec_env("QuadDOB/Hover-v3", 4, loop_randomization={
        "groups": 2, "extra_latency": [0.0, 0.02]}).close()
    assert built == ["hover-calm"] * 3
