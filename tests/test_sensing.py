"""Sensing every policy flies through (``quad_dob_env.sensing``): the identity keeps v1,
the presets change what the controllers read and nothing exogenous, and the residual's
observation comes from the measurement record alone."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from quad_dob_baselines import make_controller
from quad_dob_composition import ResidualVectorEnv
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.envs import QuadrotorBatch, QuadrotorEnv, QuadrotorVectorEnv
from quad_dob_env.residual.residual_kernels import body_frame_errors
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.sensing import (
    SENSING_PRESETS,
    SENSING_SOURCES,
    SensingStage,
    SensorSuite,
    delay_steps,
)
from quad_dob_env.sensing.models import MOCAP
from quad_dob_env.so3 import exp as so3_exp
from quad_dob_env.variation import SensorNoise
from quad_dob_training.policies import fly_policy, make_policy

# Final positions (and record lengths) of v1 flights on seeds 9001 and 9002, from the tree
# before sensing existed (commit e138bb3), where the controllers read the true state. Both
# trees gave these bit for bit on the project's VM (same numpy, numba and CPU); the test
# allows 1e-9 m so that another CPU's rounding cannot fail it, far below any change of an
# equation.
V1_FLIGHTS = {
    ("paper-II", "geometric-ndob"): [
        (4.016907961274374, 0.038280795806895654, 0.6310702763413453, 1000)] * 2,
    ("dryden-helix-gusts", "geometric-ndob:tuned"): [
        (3.9997213450948226, -0.023279804122310503, 2.649993491057723, 1000),
        (4.00568160724737, -0.02390359229910093, 2.6679814074588015, 1000)],
    ("gusty-hover", "pid"): [
        (0.006834793754026142, 0.0011749231047759423, 1.0050538135362916, 1000),
        (-0.00031535299020413453, -0.0021794504579655248, 1.003991973229337, 1000)],
    ("dryden-helix-gusts", "residual"): [
        (3.991462433472862, -0.0193439583942066, 2.6064854690900487, 1000),
        (4.000247357217025, -0.011166854002729997, 2.617000159252946, 1000)],
}


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "policy"), list(V1_FLIGHTS))
def test_ideal_sensing_flies_v1s_flights(scenario, policy):
    flown = make_scenario(scenario, sensing="ideal")
    assert flown.loop.sensing is None  # the identity, the default
    flights = fly_policy(make_policy(policy), flown, [9001, 9002])
    for flight, (*position, length) in zip(flights, V1_FLIGHTS[scenario, policy], strict=True):
        assert len(flight.position) == length
        # a torch policy's matrix products round by the CPU's vector width (1.8e-9 m apart
        # on a 2026-12-05 VM), still far below any change of an equation
        tolerance = 1e-8 if policy == "residual" else 1e-9
        np.testing.assert_allclose(flight.position[-1], position, rtol=0, atol=tolerance)
        np.testing.assert_array_equal(flight.estimated_position, flight.position)


def test_the_identity_keeps_the_compiled_pass_and_the_truths_arrays():
    env = ResidualVectorEnv(2, "gusty-hover", base_controller="geometric-ndob:tuned")
    core = env.core
    assert core.sensing.identity and env.residual._fused is not None
    assert core.measurement.position is core.state.position
    sensed = ResidualVectorEnv(2, "gusty-hover", {"sensing": "mocap"},
                               base_controller="geometric-ndob:tuned")
    assert not sensed.core.sensing.identity and sensed.residual._fused is None


def _fly_base(sensing, steps=300, scenario="dryden-helix-gusts", seeds=(4, 5)):
    env = ResidualVectorEnv(len(seeds), scenario, {"sensing": sensing},
                            base_controller="geometric-ndob:tuned")
    env.reset(seed=list(seeds))
    paths, winds, measured = [], [], []
    for _ in range(steps):
        _, _, terminated, _, info = env.step(np.zeros((len(seeds), 4)))
        assert not terminated.any()
        paths.append(env.core.state.position.copy())
        winds.append(info["wind"])
        measured.append(info["estimate"]["position"])
    return env, np.array(paths), np.array(winds), np.array(measured)


def test_mocap_flies_the_base_on_its_estimate_not_the_truth():
    _, ideal, ideal_wind, _ = _fly_base(None)
    _, sensed, sensed_wind, measured = _fly_base("mocap")
    assert np.abs(sensed - ideal).max() > 1e-5  # the base read something else
    assert np.abs(measured - sensed).max() > 1e-5  # and that was not the truth
    # an estimate of the truth: within a couple of centimetres, as the flight is
    assert np.abs(measured - sensed).max() < 0.02
    assert np.abs(sensed - ideal).max() < 0.05
    np.testing.assert_array_equal(sensed_wind, ideal_wind)  # the same air


@pytest.mark.parametrize("sensing", ["mocap", "gnss-imu", SensorNoise(position_std=0.01),
                                     {"position_std": 0.02, "delay_steps": 2}])
def test_sensing_changes_no_exogenous_draw(sensing):
    """Wind, gusts, the reference drawn, its start, the start offsets and the randomised
    physics are the same for the same seed, with sensing on or off."""
    options = {"initial_position_noise": 0.05, "initial_attitude_noise": 0.05,
               "reference_start_spread": 2.0}
    # a family of 32 references in randomised wind with randomised physics
    plain = QuadrotorVectorEnv(3, "random-lemniscates", options)
    sensed = QuadrotorVectorEnv(3, "random-lemniscates", {**options, "sensing": sensing})
    starts = []
    for env in (plain, sensed):
        _, info = env.reset(seed=11)
        starts.append((env.core.state.copy(), env.core.reference_row.copy(), info["sampled"]))
    (state, rows, sampled), (state2, rows2, sampled2) = starts
    for name in ("position", "velocity", "rotation"):
        np.testing.assert_array_equal(getattr(state, name), getattr(state2, name))
    np.testing.assert_array_equal(rows, rows2)
    for key, value in sampled.items():
        np.testing.assert_array_equal(value, sampled2[key])
    hover = np.zeros((3, 4))
    for _ in range(50):  # the wind at the vehicle is a function of time: equal throughout
        winds = [env.step(hover)[4]["wind"] for env in (plain, sensed)]
        np.testing.assert_array_equal(*winds)
        np.testing.assert_array_equal(plain.core.disturbance_torque,
                                      sensed.core.disturbance_torque)


def test_each_sensor_draws_its_own_noise():
    noisier = dataclasses.replace(MOCAP, pose=dataclasses.replace(
        MOCAP.pose, position_std=10 * MOCAP.pose.position_std))
    rings = []
    for sensing in (MOCAP, noisier):
        core = QuadrotorBatch(make_scenario("hover-calm", sensing=sensing), 2)
        core.reset(np.arange(2), [np.random.default_rng(3), np.random.default_rng(4)])
        rings.append(core.sensing.ring.copy())
    gyro_to_rotors = slice(16, 26)
    np.testing.assert_array_equal(rings[0][..., gyro_to_rotors], rings[1][..., gyro_to_rotors])
    assert np.abs(rings[0][..., :3] - rings[1][..., :3]).max() > 0


def test_the_residual_observation_is_rebuilt_from_the_measurement_alone():
    """Under mocap: the 24 env entries and the 16 residual entries from the measurement
    record, the reference and a second controller fed nothing but measurements and the
    applied command; bit for bit (as float32), and unlike what the truth would give."""
    env = ResidualVectorEnv(2, "dryden-helix-gusts", {"sensing": "mocap"},
                            base_controller="geometric-ndob:tuned")
    core, residual = env.core, env.residual
    twin = make_controller("geometric-ndob:tuned", core.vehicle)
    obs, _ = env.reset(seed=[21, 22])
    twin.reset(2, core.vehicle, core.scenario.dt, actuation=core.scenario.actuation)
    actions = np.random.default_rng(0).uniform(-0.3, 0.3, (40, 2, 4))
    before = core.measurement.copy()
    for action in actions:
        twin_thrust, twin_moment = twin.compute(core.time, before, core.reference)
        np.testing.assert_array_equal(twin_thrust, residual.base_thrust)
        np.testing.assert_array_equal(twin_moment, residual.base_moment)
        np.testing.assert_array_equal(twin.diagnostics["force_estimate"],
                                      residual.force_estimate)
        obs, *_ = env.step(action)
        twin.applied(before, core.applied.thrust, core.applied.moment)
        before = core.measurement.copy()
        rebuilt = _observation_from(core, before)
        np.testing.assert_array_equal(obs[:, :24], rebuilt[:, :24])
        np.testing.assert_array_equal(obs[:, 24 + 10:], rebuilt[:, 24:])
        truth = _observation_from(core, core.state)
        assert np.abs(obs[:, :6] - truth[:, :6]).max() > 0


def _observation_from(core, state) -> np.ndarray:
    """The env's 24 entries (position, velocity errors, R, Ω, ẍ_d, b1d) and the residual's
    body-frame errors from ``state`` and the reference, written out here."""
    ref = core.reference
    errors = np.empty((core.n, 6))
    for i in range(core.n):
        errors[i] = body_frame_errors(
            tuple(state.position[i]), tuple(state.velocity[i]),
            tuple(state.rotation[i].reshape(9)), tuple(ref.position[i]), tuple(ref.velocity[i]))
    env_part = np.concatenate([state.position - ref.position, state.velocity - ref.velocity,
                               state.rotation.reshape(-1, 9), state.angular_velocity,
                               ref.acceleration, ref.heading], axis=1)
    return np.concatenate([env_part, errors], axis=1).astype(np.float32)


def test_extra_latency_and_motor_scale_are_checked_and_resolved_on_the_grid():
    scenario = make_scenario("gusty-hover", extra_latency=0.025, motor_time_constant_scale=2)
    assert delay_steps(scenario.loop.extra_latency, scenario.dt) == 3
    core = QuadrotorBatch(scenario, 1)
    assert core.sensing.pose_delay.tolist() == [3] and core.sensing.imu_delay == 3
    assert not core.sensing.identity
    with pytest.raises(ValueError, match="extra_latency must be >= 0"):
        make_scenario("gusty-hover", extra_latency=-0.01)
    with pytest.raises(ValueError, match=r"motor_time_constant_scale = 2 .* set motor_lag=True"):
        make_scenario("paper-II", motor_time_constant_scale=2)
    with pytest.raises(ValueError, match="motor_time_constant_scale must be > 0"):
        make_scenario("gusty-hover", motor_time_constant_scale=0)


def test_a_slower_motor_follows_its_command_with_the_scaled_time_constant():
    tau = make_scenario("gusty-hover").vehicle.motor_time_constant
    for scale in (1.0, 2.0):
        core = QuadrotorBatch(make_scenario("hover-calm", drag=True, motor_lag=True,
                                            motor_time_constant_scale=scale), 1)
        core.reset(np.zeros(1, dtype=np.intp), [np.random.default_rng(0)])  # rotors at hover
        weight = core.vehicle.mass * core.vehicle.gravity
        command = core.action_map.to_actions(np.array([1.5 * weight]), np.zeros((1, 3)))
        core.step(command)
        # the mean over the step of a first-order lag from the hover thrust
        time_constant, dt = scale * tau, core.scenario.dt
        share = time_constant / dt * (1 - np.exp(-dt / time_constant))
        expected = 1.5 * weight + (weight - 1.5 * weight) * share
        np.testing.assert_allclose(core.applied.thrust, [expected], rtol=1e-9)


def test_sensing_options_by_name_record_or_dict_with_clear_errors():
    assert make_scenario("gusty-hover", sensing="mocap").loop.sensing is SENSING_PRESETS["mocap"]
    assert make_scenario("gusty-hover", sensing="ideal").loop.sensing is None
    # ``sensors``, sensing's SensorNoise spelling, is a flat key for ``sensing``
    noisy = make_scenario("gusty-hover", sensors={"position_std": 0.01})
    assert noisy.loop.sensing == SensorNoise(position_std=0.01)
    assert noisy.with_changes(sensing="mocap").loop.sensing is SENSING_PRESETS["mocap"]
    with pytest.raises(ValueError,
                       match=r"unknown sensing preset 'mocup'.*did you mean 'mocap'"):
        make_scenario("gusty-hover", sensing="mocup")
    with pytest.raises(ValueError, match=r"sensors is the sensing=SensorNoise"):
        make_scenario("gusty-hover", sensing="mocap", sensors={"position_std": 0.01})
    with pytest.raises(ValueError, match="unknown SensorSuite field 'imus'"):
        make_scenario("gusty-hover", sensing={"pose": {}, "imus": {}})
    suite = dataclasses.asdict(MOCAP)
    assert make_scenario("gusty-hover", sensing=suite).loop.sensing == MOCAP
    with pytest.raises(ValueError, match=r"position_bandwidth = 200.0 rad/s times the pose "
                                         r"fix.*at most 100 rad/s"):
        SensorSuite(**{**suite, "estimator": {"position_bandwidth": 200.0,
                                              "attitude_bandwidth": 5.0}})
    with pytest.raises(ValueError, match=r"PoseSensor\.rate must be > 0"):
        dataclasses.replace(MOCAP.pose, rate=0.0)


def test_every_preset_number_has_a_source():
    for name, suite in SENSING_PRESETS.items():
        if suite is None:
            continue
        sources = SENSING_SOURCES[name]
        fields = [f"{part}.{field.name}" for part in ("pose", "imu", "rotors", "estimator")
                  for field in dataclasses.fields(getattr(suite, part)) if field.name != "kind"]
        assert sorted(fields) == sorted(sources), name
        assert all(len(text) > 10 for text in sources.values())


def test_info_reports_the_wind_at_the_vehicle_and_the_estimate():
    env = QuadrotorEnv("dryden-helix-gusts", {"sensing": "gnss-imu"})
    _, info = env.reset(seed=0)
    for _ in range(5):
        _, _, _, _, info = env.step(np.zeros(4, np.float32))
    assert np.linalg.norm(info["wind"]) > 1.0  # a 6 m/s mean wind
    assert set(info["estimate"]) == {"position", "velocity", "rotation", "angular_velocity"}
    assert not np.array_equal(info["estimate"]["position"], env.core.state.position[0])
    calm = QuadrotorEnv("hover-calm")
    calm.reset(seed=0)
    assert not calm.step(np.zeros(4, np.float32))[4]["wind"].any()


def test_the_estimator_integrates_a_spin_up_exactly():
    """Noise-free sensors on a vehicle spinning up about z at a constant 2 rad/s²: the
    trapezoid of the gyroscope's last two readings integrates the linear rate exactly
    (rotations about one axis compose), where the newest reading alone would leave
    Ω̇ dt / (2 ω_R) = 2 mrad of lag against the mocap fixes."""
    quiet = dataclasses.replace(
        MOCAP, pose=dataclasses.replace(MOCAP.pose, position_std=0.0, attitude_std=0.0),
        imu=dataclasses.replace(MOCAP.imu, gyroscope_noise_density=0.0,
                                accelerometer_noise_density=0.0, gyroscope_bias_walk=0.0,
                                accelerometer_bias_walk=0.0),
        rotors=dataclasses.replace(MOCAP.rotors, speed_std=0.0))
    vehicle = make_scenario("hover-calm").vehicle
    n, dt, spin_up = 2, 0.01, 2.0
    truth = VehicleState.at_rest(n, (0.0, 0.0, 1.0))
    physics = (np.full(n, vehicle.mass * vehicle.gravity), np.zeros((n, 3)),
               np.full(n, vehicle.mass), np.full((n, 4), vehicle.mass * vehicle.gravity / 4))
    stage = SensingStage(quiet, 0.0, truth, physics, vehicle, dt)
    steps, everyone = np.zeros(n, dtype=np.int64), np.arange(n)
    stage.start(0, np.random.default_rng(0))
    stage.start(1, np.random.default_rng(1))
    stage.measure(everyone, steps, reset=True)
    for step in range(1, 201):
        time = step * dt
        truth.rotation[:] = so3_exp(np.array([[0.0, 0.0, 0.5 * spin_up * time**2]]))
        truth.angular_velocity[:] = (0.0, 0.0, spin_up * time)
        steps[:] = step
        stage.measure(everyone, steps, reset=False)
    measured = stage.measurement
    np.testing.assert_allclose(measured.rotation, truth.rotation, rtol=0, atol=1e-9)
    np.testing.assert_allclose(measured.angular_velocity, truth.angular_velocity, atol=1e-12)
    np.testing.assert_allclose(measured.position, truth.position, rtol=0, atol=1e-9)


def test_unstable_estimator_gains_are_refused_with_the_loop_named():
    # ω_p T = 0.6 passes the nominal check (below 1) but the position loop grows 1.45x a fix
    fast = dataclasses.replace(
        MOCAP, pose=dataclasses.replace(MOCAP.pose, latency=0.0),
        estimator=dataclasses.replace(MOCAP.estimator, position_bandwidth=60.0))
    with pytest.raises(ValueError, match=r"position loop is unstable .*error growth 1\.45"):
        QuadrotorBatch(make_scenario("hover-calm", sensing=fast), 1)
    slow_imu = dataclasses.replace(MOCAP, imu=dataclasses.replace(MOCAP.imu, latency=0.05))
    with pytest.raises(ValueError, match=r"IMU's latency 0\.05 s is above the pose fix's"):
        QuadrotorBatch(make_scenario("hover-calm", sensing=slow_imu), 1)


def test_readings_at_a_reset_are_the_hovering_rotors_and_refresh_every_step():
    """At a reset nothing is applied yet but the rotors turn at hover: a delayed IMU must
    not feed the filter free fall (it did: 0.5 m/s of vertical velocity error at 50 ms)."""
    core = QuadrotorBatch(make_scenario("hover-calm", sensing="mocap", extra_latency=0.05,
                                        initial_position_noise=0.0,
                                        initial_attitude_noise=0.0), 1)
    core.reset(np.zeros(1, dtype=np.intp), [np.random.default_rng(0)])
    weight = core.vehicle.mass * core.vehicle.gravity
    np.testing.assert_allclose(core.measurement.accelerometer[0, 2], core.vehicle.gravity,
                               atol=0.05)
    hover_speed = np.sqrt(weight / 4 / core.vehicle.thrust_coefficient)
    np.testing.assert_allclose(core.measurement.rotor_speeds[0], hover_speed, atol=5.0)
    worst = 0.0
    for _ in range(60):
        core.step(np.zeros((1, 4)))  # hover command
        worst = max(worst, abs(core.measurement.velocity[0, 2] - core.state.velocity[0, 2]))
    assert worst < 0.02
    ideal = QuadrotorBatch(make_scenario("hover-calm"), 1)
    ideal.reset(np.zeros(1, dtype=np.intp), [np.random.default_rng(0)])
    first = ideal.measurement.accelerometer.copy()
    ideal.step(np.full((1, 4), 0.5))  # more thrust: the ideal accelerometer reads it
    assert ideal.measurement.accelerometer[0, 2] > first[0, 2] + 1.0


def test_a_single_marker_s_fix_corrects_the_position_and_leaves_the_attitude_to_the_gyro():
    """``mocap-position``: with a fix whose attitude is off by 0.3 rad of noise, ``mocap``
    pulls the estimate's attitude about; a single marker's fix does not read it, and the
    position still follows the fix."""
    noisy = dataclasses.replace(MOCAP.pose, attitude_std=0.3)
    errors = {}
    for kind in ("mocap", "mocap-position"):
        suite = dataclasses.replace(MOCAP, pose=dataclasses.replace(noisy, kind=kind))
        env = QuadrotorVectorEnv(2, "hover-calm", {"sensing": suite})
        env.reset(seed=[3, 4])
        attitude, position = 0.0, 0.0
        for _ in range(100):
            _, _, _, _, info = env.step(np.zeros((2, 4), np.float32))
            truth = env.core.state
            turn = np.einsum("nji,njk->nik", truth.rotation, info["estimate"]["rotation"])
            attitude = max(attitude, float(np.abs(turn - np.eye(3)).max()))
            position = max(position, float(np.abs(info["estimate"]["position"]
                                                   - truth.position).max()))
        errors[kind] = attitude, position
    assert errors["mocap"][0] > 0.01  # the noisy attitude fixes reached the estimate
    assert errors["mocap-position"][0] < 1e-3  # the gyroscope's alone
    assert errors["mocap-position"][1] < 0.005  # the fix's position still holds it
