import numpy as np
import pytest

from quad_dob_env.envs import QuadrotorEnv
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.variation import SensorNoise

STILL = {"initial_position_noise": 0.0, "initial_attitude_noise": 0.0}


def fly_pair(sensors, steps=400):
    clean, noisy = QuadrotorEnv("hover-calm", STILL), QuadrotorEnv(
        "hover-calm", {**STILL, "sensors": sensors})
    first = [clean.reset(seed=1)[0]], [noisy.reset(seed=1)[0]]
    rewards = [], []
    actions = np.random.default_rng(0).uniform(-0.05, 0.05, (steps, 4))
    for action in actions:
        for env, observations, reward_list in zip((clean, noisy), first, rewards, strict=True):
            obs, reward, *_ = env.step(action)
            observations.append(obs)
            reward_list.append(reward)
    return np.array(first[0]), np.array(first[1]), rewards


def test_sensor_noise_has_the_configured_spread_and_leaves_the_truth_alone():
    sensors = SensorNoise(position_std=0.05, velocity_std=0.1, attitude_std=0.02, rate_std=0.05)
    clean, noisy, (clean_rewards, noisy_rewards) = fly_pair(sensors, steps=2000)
    error = noisy - clean
    np.testing.assert_allclose(error[:, 0:3].std(), 0.05, rtol=0.1)
    np.testing.assert_allclose(error[:, 3:6].std(), 0.1, rtol=0.1)
    np.testing.assert_allclose(error[:, 15:18].std(), 0.05, rtol=0.1)
    assert abs(error[:, 0:6].mean()) < 0.01
    rotations = noisy[:, 6:15].reshape(-1, 3, 3).astype(float)
    assert np.abs(rotations @ np.swapaxes(rotations, 1, 2) - np.eye(3)).max() < 1e-5
    # an attitude perturbation of 0.02 rad per axis
    assert 0.01 < np.abs(error[:, 6:15]).mean() < 0.04
    assert clean_rewards == noisy_rewards  # reward sees the true state


def test_sensor_delay_returns_the_reading_of_delay_steps_ago():
    clean, delayed, _ = fly_pair(SensorNoise(delay_steps=3), steps=50)
    np.testing.assert_array_equal(delayed[3:], clean[:-3])
    for k in range(3):
        np.testing.assert_array_equal(delayed[k], clean[0])


def test_randomization_draws_within_ranges_changes_the_physics_and_is_seeded():
    options = {**STILL, "randomization": {"mass": (1.2, 1.3), "drag": (0.5, 1.5)}}
    env = QuadrotorEnv("hover-calm", options)
    _, info = env.reset(seed=4)
    sampled = info["sampled"]
    nominal = env.scenario.vehicle.mass
    assert 1.2 * nominal <= sampled["mass"] <= 1.3 * nominal
    assert 0.5 <= sampled["drag_scale"] <= 1.5 and sampled["inertia_scale"] == 1.0
    for _ in range(100):  # hover thrust for the nominal mass: the heavier vehicle sinks
        env.step(np.zeros(4))
    assert env.core.state.position[0, 2] < 0.9
    assert QuadrotorEnv("hover-calm", options).reset(seed=4)[1]["sampled"] == sampled
    assert QuadrotorEnv("hover-calm", options).reset(seed=5)[1]["sampled"] != sampled


def test_randomized_physics_is_the_nominal_scaled_by_the_reported_draws():
    options = {"randomization": {"mass": (0.8, 1.2), "inertia": (0.7, 1.3), "drag": (0.5, 2.0)}}
    env = QuadrotorEnv("dryden-helix-gusts", options)  # a scenario with linear + quadratic drag
    for seed in (0, 1):
        _, info = env.reset(seed=seed)
        core, sampled = env.core, info["sampled"]
        nominal = core._nominal  # the vehicle's BodyArrays, N = 1
        inertia, inertia_inverse, drag = nominal.inertia, nominal.inertia_inverse, nominal.drag
        assert np.all(drag[0] > 0)
        np.testing.assert_array_equal(core.mass, [sampled["mass"]])
        np.testing.assert_array_equal(core.inertia, inertia * sampled["inertia_scale"])
        np.testing.assert_array_equal(core.inertia_inverse,
                                      inertia_inverse / sampled["inertia_scale"])
        np.testing.assert_array_equal(core.drag, drag * sampled["drag_scale"])  # every column


def test_random_wind_draws_are_reported():
    env = QuadrotorEnv("gusty-hover")
    _, info = env.reset(seed=0)
    assert 0.0 <= info["sampled"]["wind_direction"] < 2 * np.pi


@pytest.mark.parametrize(("options", "message"), [
    ({"sensors": {"position_std": -1.0}}, "position_std must be >= 0"),
    ({"sensors": {"delay": 2}}, r"unknown SensorNoise field 'delay'.*delay_steps"),
    ({"sensors": {"delay_steps": 1.5}}, "delay_steps must be an integer"),
    ({"randomization": {"mass": (1.2, 0.8)}}, "low <= high"),
    ({"randomization": {"mass": (0.0, 1.0)}}, "mass must be > 0"),
    ({"randomization": "heavy"}, "must be a Randomization, a dict"),
])
def test_bad_sensor_and_randomization_specs_are_named(options, message):
    with pytest.raises(ValueError, match=message):
        make_scenario("hover-calm", **options)
