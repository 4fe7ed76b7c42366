"""Benchmark v4's preset (``quad_dob_env.benchmark_v4``): its values are its own, sourced,
reach the loop they correct, and leave v1-v3 (their presets and vehicles) as they were."""

from __future__ import annotations

import math

import numpy as np
import pytest

from quad_dob_baselines import make_controller
from quad_dob_env.benchmark_v3 import REAL_LOOPS
from quad_dob_env.benchmark_v4 import ABLATION_ENDS, V4_LOOPS, V4_SOURCES
from quad_dob_env.envs.core import QuadrotorBatch
from quad_dob_env.loop_options import LoopOptions
from quad_dob_env.params import VEHICLES, AirframeDrag
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.trajectories import RampedStart
from quad_dob_training.wind_tunnel.drag_fit import DragCoefficients, exponent


def test_every_v4_value_has_a_source_and_its_ends_hold_the_nominal():
    v4 = V4_LOOPS["neural-fly"]
    for key in ("estimator_wrench", "indi.actuator_state", "airframe_drag", "reference_ramp",
                "throttle_map.thrust_model_factor", "vibration.level", "vibration.blades",
                "vibration.raw_rate", "vibration.batch_rate", "vibration.cutoff"):
        assert V4_SOURCES.get(key), f"{key} has no source"
    low, high = ABLATION_ENDS["throttle_map.thrust_model_factor"]
    assert low <= v4.throttle_map.thrust_model_factor <= high
    low, high = ABLATION_ENDS["vibration.level"]
    assert low <= v4.vibration.rotor_level <= high


def test_v4_resolves_its_own_values_and_v3_keeps_its():
    v4 = LoopOptions.preset("v4", "neural-fly", dt=0.02)
    v3 = LoopOptions.preset("v3", "neural-fly", dt=0.02)
    own = V4_LOOPS["neural-fly"]
    assert v4.estimator_wrench == "commanded" and v3.estimator_wrench == "applied"
    assert v4.airframe_drag == own.airframe_drag and v3.airframe_drag is None
    assert v4.imu_vibration is None and v4.imu_vibration_tones == own.vibration
    assert v3.imu_vibration is not None and v3.imu_vibration_tones is None
    assert v4.throttle_map.thrust_model_factor == own.throttle_map.thrust_model_factor
    assert v3.throttle_map == REAL_LOOPS["neural-fly"].throttle_map
    # v3's loop otherwise
    for key in ("motor_time_constants", "model_tolerance", "gyro_cutoff", "inner_rate",
                "pose_latency_on_ticks", "sensing"):
        assert getattr(v4, key) == getattr(v3, key), key


@pytest.mark.parametrize(("option", "field", "off"), [
    ("airframe_drag", "airframe_drag", None),
    ("imu_vibration_tones", "imu_vibration_tones", None),
])
def test_a_v4_mechanism_is_switched_off_with_false(option, field, off):
    loop = LoopOptions(benchmark="v4", **{option: False}).resolved(VEHICLES["neural-fly"], 0.02)
    assert getattr(loop, field) is off
    told = LoopOptions(benchmark="v4", estimator_wrench="applied").resolved(
        VEHICLES["neural-fly"], 0.02)
    assert told.estimator_wrench == "applied"


def test_the_physics_flies_v4s_drag_and_the_preset_keeps_its_own():
    preset = VEHICLES["neural-fly"]
    fitted = V4_LOOPS["neural-fly"].airframe_drag
    assert preset.drag_quadratic != fitted.body_quadratic
    assert preset.rotor_drag_coefficient != fitted.rotor_drag_coefficient
    core = QuadrotorBatch(make_scenario("figure8-wind-12.1", benchmark="v4"), 2)
    np.testing.assert_array_equal(core.drag[:, 3:], np.tile(fitted.body_quadratic, (2, 1)))
    assert core.loop.model.drag_coefficient == fitted.rotor_drag_coefficient
    assert core.vehicle == preset  # the controllers' model: the preset
    v3 = QuadrotorBatch(make_scenario("figure8-wind-12.1", benchmark="v3"), 2)
    np.testing.assert_array_equal(v3.drag[:, 3:], np.tile(preset.drag_quadratic, (2, 1)))


def test_airframe_drag_needs_drag_and_is_checked():
    with pytest.raises(ValueError, match="airframe_drag acts on the air-relative velocity"):
        make_scenario("hover-calm", airframe_drag=AirframeDrag((0.1, 0.1, 0.1), 1e-4))
    with pytest.raises(ValueError, match="body_quadratic must be three finite numbers >= 0"):
        AirframeDrag((0.1, -0.1, 0.1), 1e-4)
    with pytest.raises(ValueError, match="rotor_drag_coefficient must be a finite number"):
        AirframeDrag((0.1, 0.1, 0.1), float("nan"))


def test_v4s_indi_models_its_actuators_at_the_classes_time_constant():
    v4 = make_controller("indi", "neural-fly", "v4")
    assert v4.actuator_state == "model"
    assert v4.actuator_time_constant == REAL_LOOPS["neural-fly"].motor_time_constants[0]
    assert make_controller("indi", "neural-fly", "v3").actuator_state == "telemetry"
    given = make_controller("indi", "neural-fly", "v4", actuator_state="telemetry")
    assert given.actuator_state == "telemetry"  # a user's option wins
    # v4's own set, searched whole; the tunnel's INDI, indi-outer, models them too
    assert v4.gain_set.tuned_for == ("v4", "neural-fly")
    assert make_controller("indi-outer", "neural-fly", "v4").actuator_state == "model"


def test_the_tunnels_reference_starts_from_rest_in_v4_alone():
    assert isinstance(make_scenario("figure8-wind-4.2", benchmark="v4").trajectory,
                      RampedStart)
    assert not isinstance(make_scenario("figure8-wind-4.2", benchmark="v3").trajectory,
                          RampedStart)
    at_speed = make_scenario("figure8-wind-4.2", benchmark="v4", reference_ramp=0.0)
    assert not isinstance(at_speed.trajectory, RampedStart)


def test_the_drag_fits_helpers():
    speeds = (4.2, 8.5, 12.1)
    assert math.isclose(exponent(speeds, [-2.0 * v**1.44 for v in speeds]), 1.44)
    drag = DragCoefficients(body=0.05, rotor=1.5e-4).airframe()
    assert drag.body_quadratic[2] / drag.body_quadratic[0] == pytest.approx(0.1 / 0.06)
    assert drag.rotor_drag_coefficient == 1.5e-4


def test_every_ablation_variant_flies_a_valid_v4_scenario(monkeypatch):
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).parents[1] / "benchmarks" / "wind_tunnel_ablation_v4.py"
    spec = importlib.util.spec_from_file_location("_ablation_v4", path)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)
    spec.loader.exec_module(module)
    table = module.variants()
    assert len(table) == 11
    for label, (options, inputs) in table.items():
        scenario = make_scenario("figure8-wind-4.2", benchmark="v4", **options)
        assert scenario.loop.benchmark == "v4", label
        with module.indi_inputs(inputs):
            indi = make_controller("indi", "neural-fly", "v4")
        assert indi.actuator_state == ("telemetry" if inputs == {} else "model"), label
    # part 1's counterparts fly v3's sets in the ablation, and v4's are back after it
    with module.v3_gains():
        assert make_controller("l1", "neural-fly", "v4").gain_set.tuned_for == ("v3",
                                                                               "neural-fly")
    assert make_controller("l1", "neural-fly", "v4").gain_set.tuned_for == ("v4", "neural-fly")
    # the paired interval: a constant difference has none, a mixed one straddles it
    assert module.paired({1: 2.0, 2: 3.0}, {1: 1.0, 2: 2.0}, False) == (1.0, 0.0, 2)
    mean, half, count = module.paired({1: 1.0, 2: -1.0, 3: 0.0}, {1: 0.0, 2: 0.0, 3: 0.0},
                                      False)
    assert mean == 0.0 and half > 0 and count == 3
    # phases differ by the short way round
    assert module.paired({1: 3.1, 2: 3.1}, {1: -3.1, 2: -3.1}, True)[0] == pytest.approx(
        6.2 - 2 * math.pi)
