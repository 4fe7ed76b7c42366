"""The sensing values a training run randomises, drawn per episode for each vehicle (issue
52): ``LoopOptions.unmodelled_pose_latency`` and ``imu_vibration_scale``, each a number or a
(low, high) range. Each vehicle's pose delay and tick and its IMU's white noise are (N,)
arrays the kernels read by vehicle, filled at reset."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.loop_options import LoopOptions
from quad_dob_env.params import VEHICLES
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.sensing.models import MOCAP

RANGES = {"unmodelled_pose_latency": (0.0, 0.03), "imu_vibration_scale": (0.5, 2.0)}
STILL = {"initial_position_noise": 0.0, "initial_attitude_noise": 0.0}
PAPER = VEHICLES["paper"]
HOVER_ROTOR = PAPER.hover_thrust / 4
PAIR_SEEDS = [3, 4]  # seeds whose two vehicles draw apart (asserted where it matters)


def _core(scenario, seeds, action_mode="thrust_moments"):
    core = QuadrotorBatch(scenario, len(seeds), action_mode=action_mode)
    core.reset(np.arange(len(seeds)), [seeding.np_random(s)[0] for s in seeds])
    return core


def _pose_oracle(latency, dt, ticks):
    """(delay in steps, tick) of a pose fix ``latency`` [s] late on the grid of ``ticks``
    ticks a step: taken ``late`` ticks before the step that reads it ends."""
    late = math.ceil(round(latency / (dt / ticks), 9))
    return late // ticks, (ticks - late % ticks) % ticks


def test_each_vehicle_reads_its_own_draws():
    """Two vehicles of one batch, a range given: each one's pose delay, tick and IMU noise
    are those of its own draw (the equations), and the two differ."""
    scenario = make_scenario("hover-calm", benchmark="v3", **RANGES)
    sensing = _core(scenario, PAIR_SEEDS).sensing
    latency, scale = sensing.drawn[:, 0], sensing.drawn[:, 1]
    ticks, dt = scenario.inner_ticks, scenario.dt
    root = math.sqrt(dt)
    gyro_vibration, accel_vibration = scenario.loop.imu_vibration
    for i in range(2):
        assert 0.0 <= latency[i] <= 0.03 and 0.5 <= scale[i] <= 2.0
        assert (sensing.pose_delay[i], sensing.pose_tick[i]) == _pose_oracle(
            MOCAP.pose.latency + latency[i], dt, ticks)
        assert sensing.gyroscope_std[i] == math.hypot(
            MOCAP.imu.gyroscope_noise_density / root, scale[i] * gyro_vibration)
        assert sensing.accelerometer_std[i] == math.hypot(
            MOCAP.imu.accelerometer_noise_density / root, scale[i] * accel_vibration)
    assert sensing.pose_delay[0] != sensing.pose_delay[1]
    assert sensing.accelerometer_std[0] != sensing.accelerometer_std[1]
    assert sensing.pose_delay.dtype == sensing.pose_tick.dtype == np.int64


def test_each_vehicle_flies_as_a_batch_of_one_with_its_draw_fixed():
    """The kernels read each vehicle's own values: vehicle i of a pair drawing from the
    ranges flies, bit for bit, as a batch of one given vehicle i's draws as fixed values
    (the same seed: the same sensor keys and rotor draws). The estimator meets each fix at
    the vehicle's own delay, so the pair's estimates differ where the singles' do."""
    pair = _core(make_scenario("hover-calm", benchmark="v3", **RANGES), PAIR_SEEDS)
    singles = [_core(make_scenario(
        "hover-calm", benchmark="v3", unmodelled_pose_latency=pair.sensing.drawn[i, 0],
        imu_vibration_scale=pair.sensing.drawn[i, 1]), [seed])
        for i, seed in enumerate(PAIR_SEEDS)]
    actions = np.array([[0.05, 0.02, -0.01, 0.0]])
    for _ in range(40):
        pair.step(np.repeat(actions, 2, axis=0))
        for i, single in enumerate(singles):
            single.step(actions)
            for name in ("position", "velocity", "rotation", "angular_velocity",
                         "gyroscope", "accelerometer"):
                np.testing.assert_array_equal(getattr(pair.measurement, name)[i],
                                              getattr(single.measurement, name)[0])
            np.testing.assert_array_equal(pair.state.position[i], single.state.position[0])
    assert not np.array_equal(pair.measurement.position[0], pair.measurement.position[1])


def _still_mocap(latency):
    return {"name": "still-mocap", "estimator": MOCAP.estimator, "rotors": MOCAP.rotors,
            "pose": {"kind": "mocap", "rate": 100.0, "latency": latency, "position_std": 0.0},
            "imu": {"gyroscope_noise_density": 0.0, "accelerometer_noise_density": 0.0,
                    "gyroscope_bias_walk": 0.0, "accelerometer_bias_walk": 0.0}}


def test_each_vehicles_fix_is_the_truth_its_own_latency_ago():
    """At 50 Hz with 5 ms ticks, two vehicles flying the same commands from the same start
    read fixes of the true pose at t_k - (latency + their own draw), on the tick grid
    (the truth flown at 200 Hz beside them)."""
    options = {"inner_rate": 200.0, "speed_motors": True, **STILL}
    latency, ticks = 0.010, 4
    fast = _core(make_scenario("hover-calm", dt=0.005, **options), [1],
                 action_mode="rotor_thrusts")
    pair = _core(make_scenario("hover-calm", dt=0.02, sensing=_still_mocap(latency),
                               pose_latency_on_ticks=True,
                               unmodelled_pose_latency=(0.0, 0.03), **options),
                 PAIR_SEEDS, action_mode="rotor_thrusts")
    sensing = pair.sensing
    late_ticks = [math.ceil(round((latency + drawn) / 0.005, 9))
                  for drawn in sensing.drawn[:, 0]]
    assert late_ticks[0] != late_ticks[1]
    assert sensing.pose_delay.tolist() == [late // ticks for late in late_ticks]
    thrusts = HOVER_ROTOR * np.array([1.3, 1.0, 0.8, 1.1])  # a climb, pitching and yawing
    allocation = PAPER.allocation_matrix

    def actions(core, n):
        one = core.action_map.to_actions(thrusts.sum()[None], (allocation[1:] @ thrusts)[None])
        return np.repeat(one, n, axis=0)

    truth = [(fast.state.position[0].copy(), fast.state.rotation[0].copy())]
    for _ in range(48):
        fast.step(actions(fast, 1))
        truth.append((fast.state.position[0].copy(), fast.state.rotation[0].copy()))
    depth = sensing.ring.shape[0]
    for k in range(1, 12):
        pair.step(actions(pair, 2))
        for i in range(2):
            if ticks * k < late_ticks[i]:  # before the start: the reset's reading
                continue
            row = sensing.ring[(k - sensing.pose_delay[i]) % depth, i]
            position, rotation = truth[ticks * k - late_ticks[i]]
            np.testing.assert_allclose(row[0:3], position, rtol=0, atol=1e-12)
            np.testing.assert_allclose(row[3:12], rotation.ravel(), rtol=0, atol=1e-12)


def test_a_fixed_value_gives_every_vehicle_the_same_arrays():
    scenario = make_scenario("hover-calm", benchmark="v3", unmodelled_pose_latency=0.013,
                             imu_vibration_scale=1.5)
    core = _core(scenario, [1, 2, 3])
    sensing = core.sensing
    expected = sensing.pose_delay_of(0.013)
    assert sensing.pose_delay.tolist() == [expected[0]] * 3
    assert sensing.pose_tick.tolist() == [expected[1]] * 3
    for stds in (sensing.gyroscope_std, sensing.accelerometer_std):
        np.testing.assert_array_equal(stds, stds[0])
    np.testing.assert_array_equal(sensing.drawn, [[0.013, 1.5]] * 3)
    for sampled in core.sampled:  # nothing drawn, nothing reported
        assert "unmodelled_pose_latency" not in sampled
        assert "imu_vibration_scale" not in sampled


def test_the_delay_lines_hold_the_deepest_delay_the_range_can_draw():
    scenario = make_scenario("hover-calm", benchmark="v3",
                             unmodelled_pose_latency=(0.0, 0.05))
    core = _core(scenario, list(range(64)))
    sensing = core.sensing
    deepest = sensing.pose_delay_of(0.05)[0]
    assert deepest > sensing.pose_delay_of(0.0)[0]
    # the deepest delay, one slot for the reading now and one for the IMU's reading before
    assert sensing.ring.shape[0] == deepest + 2
    assert sensing.pose_delay.max() == deepest  # drawn by some of the 64
    for _ in range(3 * deepest):  # read from every slot without an error
        core.step(np.zeros((64, 4)))
    assert np.isfinite(core.measurement.position).all()


def test_seeded_draws_repeat_and_reach_the_reset_info():
    env = gym.make("QuadDOB/Hover-v3", scenario_options=RANGES)
    _, first = env.reset(seed=3)
    _, again = env.reset(seed=3)
    _, other = env.reset(seed=4)
    assert first["sampled"] == again["sampled"]
    for key, (low, high) in RANGES.items():
        assert low <= first["sampled"][key] <= high
        assert first["sampled"][key] != other["sampled"][key]


def test_switching_a_range_on_changes_no_other_draw():
    off = gym.make("QuadDOB/Hover-v3", scenario_options={"rotor_thrust_mismatch": 0.1})
    on = gym.make("QuadDOB/Hover-v3", scenario_options={"rotor_thrust_mismatch": 0.1,
                                                        **RANGES})
    _, info_off = off.reset(seed=7)
    _, info_on = on.reset(seed=7)
    shared = {key: value for key, value in info_on["sampled"].items() if key not in RANGES}
    assert shared == info_off["sampled"]
    core_on, core_off = on.unwrapped.core, off.unwrapped.core
    np.testing.assert_array_equal(core_on.sensing.keys, core_off.sensing.keys)
    np.testing.assert_array_equal(core_on.sensing.true_bias, core_off.sensing.true_bias)
    np.testing.assert_array_equal(core_on.state.position, core_off.state.position)


def test_one_range_switched_on_draws_the_other_as_before():
    # one uniform per value, drawn whether it is a range or not
    both = _core(make_scenario("hover-calm", benchmark="v3", **RANGES), PAIR_SEEDS)
    latency = _core(make_scenario("hover-calm", benchmark="v3", unmodelled_pose_latency=(
        0.0, 0.03)), PAIR_SEEDS)
    scale = _core(make_scenario("hover-calm", benchmark="v3", imu_vibration_scale=(
        0.5, 2.0)), PAIR_SEEDS)
    np.testing.assert_array_equal(latency.sensing.drawn[:, 0], both.sensing.drawn[:, 0])
    np.testing.assert_array_equal(scale.sensing.drawn[:, 1], both.sensing.drawn[:, 1])


def test_a_range_of_one_value_flies_as_that_value():
    ranged = _core(make_scenario("hover-calm", benchmark="v3",
                                 unmodelled_pose_latency=(0.013, 0.013),
                                 imu_vibration_scale=[1.5, 1.5]), PAIR_SEEDS)
    fixed = _core(make_scenario("hover-calm", benchmark="v3", unmodelled_pose_latency=0.013,
                                imu_vibration_scale=1.5), PAIR_SEEDS)
    for _ in range(20):
        for core in (ranged, fixed):
            core.step(np.full((2, 4), 0.05))
    np.testing.assert_array_equal(ranged.measurement.position, fixed.measurement.position)
    np.testing.assert_array_equal(ranged.measurement.accelerometer,
                                  fixed.measurement.accelerometer)
    assert ranged.sampled[0]["unmodelled_pose_latency"] == 0.013


def test_a_range_is_kept_as_given_and_round_trips_through_the_flat_keys():
    loop = LoopOptions(unmodelled_pose_latency=[0.0, 0.02], imu_vibration_scale=2)
    assert loop.unmodelled_pose_latency == (0.0, 0.02) and loop.imu_vibration_scale == 2.0
    assert LoopOptions.from_keys(loop.keys()) == loop


@pytest.mark.parametrize(("options", "message"), [
    ({"unmodelled_pose_latency": (0.02, 0.01)},
     r"unmodelled_pose_latency: a range is \(low, high\) with low <= high"),
    ({"unmodelled_pose_latency": (-0.01, 0.02)},
     r"unmodelled_pose_latency\[0\] must be >= 0"),
    ({"unmodelled_pose_latency": (0.0, 0.01, 0.02)},
     r"unmodelled_pose_latency must be a latency in seconds: a number, or a \(low, high\) "
     r"range drawn uniformly per episode"),
    ({"unmodelled_pose_latency": "0.01"}, r"unmodelled_pose_latency must be a latency"),
    ({"imu_vibration_scale": True}, r"imu_vibration_scale must be a factor on imu_vibration"),
    ({"imu_vibration_scale": (1.0, float("nan"))}, r"imu_vibration_scale\[1\] must be finite"),
])
def test_a_bad_value_or_range_is_refused_with_what_is_allowed(options, message):
    with pytest.raises(ValueError, match=message):
        LoopOptions(**options)


def test_a_range_needs_the_part_it_draws_for():
    with pytest.raises(ValueError, match=r"unmodelled_pose_latency \(0 to 0\.02 s\) delays a "
                                         r"sensor suite's pose fix"):
        make_scenario("hover-calm", unmodelled_pose_latency=(0.0, 0.02))
    with pytest.raises(ValueError, match=r"imu_vibration_scale = \(0\.5, 2\.0\) scales the "
                                         r"IMU's vibration, but .* has none: give imu_vibration"):
        make_scenario("hover-calm", sensing="mocap", imu_vibration_scale=(0.5, 2.0))
