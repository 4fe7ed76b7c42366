import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import quad_dob_env  # noqa: F401
from quad_dob_env.envs import QuadrotorBatch, QuadrotorEnv
from quad_dob_env.scenarios import make_scenario

IDS = ["QuadDOB/Hover-v1", "QuadDOB/Track-v1"]
STILL = {"initial_position_noise": 0.0, "initial_attitude_noise": 0.0}


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_env_checker_passes(env_id):
    env = gym.make(env_id)
    gym_check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", IDS)
def test_stable_baselines3_env_checker_passes(env_id):
    sb3_check_env(gym.make(env_id).unwrapped, warn=True)


def rollout(env, seed, steps=300, action_seed=1):
    actions = np.random.default_rng(action_seed).uniform(-0.3, 0.3, (steps, 4))
    observations = [env.reset(seed=seed)[0]]
    for action in actions:
        obs, reward, terminated, truncated, _ = env.step(action)
        observations.append(np.append(obs, reward))
        if terminated or truncated:
            observations.append(env.reset()[0])
    return observations


def test_same_seed_gives_bit_identical_rollouts():
    first = rollout(gym.make("QuadDOB/Hover-v1"), seed=42)
    second = rollout(gym.make("QuadDOB/Hover-v1"), seed=42)
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))
    other = rollout(gym.make("QuadDOB/Hover-v1"), seed=43)
    assert not np.array_equal(first[0], other[0])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["hover-step-force", "dryden-helix-gusts"])
def test_a_batch_of_64_equals_64_single_runs(name):
    n, steps = 64, 150
    scenario = make_scenario(name, duration=1.0)
    batch = QuadrotorBatch(scenario, n)
    batch.reset(np.arange(n), [seeding.np_random(1000 + i)[0] for i in range(n)])
    actions = np.random.default_rng(5).uniform(-0.2, 0.2, (steps, n, 4))
    singles = [QuadrotorEnv(scenario) for _ in range(n)]
    single_obs = [env.reset(seed=1000 + i)[0] for i, env in enumerate(singles)]
    np.testing.assert_allclose(batch.obs, np.array(single_obs), rtol=0, atol=1e-12)
    for step in range(steps):
        batch.step(actions[step])
        for i, env in enumerate(singles):
            obs, reward, terminated, _, _ = env.step(actions[step, i])
            np.testing.assert_allclose(batch.obs[i], obs, rtol=0, atol=1e-12)
            assert batch.rewards[i] == pytest.approx(reward, abs=1e-12)
            assert batch.terminated[i] == terminated
        np.testing.assert_allclose(batch.state.position,
                                   [env.core.state.position[0] for env in singles], atol=1e-12)


def test_hover_action_holds_a_still_start_in_both_action_modes():
    for mode in ("thrust_moments", "rotor_thrusts"):
        env = QuadrotorEnv("hover-calm", STILL, action_mode=mode)
        env.reset(seed=0)
        for _ in range(1000):
            _, reward, terminated, truncated, info = env.step(np.zeros(4))
        assert truncated and not terminated and info["termination_reason"] == "time_limit"
        assert np.abs(info["position_error"]).max() < 1e-9
        assert reward == pytest.approx(1.0, abs=1e-8)


def test_applied_thrust_is_what_moved_the_vehicle():
    env = QuadrotorEnv("hover-calm", STILL)
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([1.0, 0.0, 0.0, 0.0]))
    vehicle = env.scenario.vehicle
    assert info["applied_thrust"] == pytest.approx(vehicle.max_total_thrust)
    vertical_speed = env.core.state.velocity[0, 2]
    expected = (info["applied_thrust"] / vehicle.mass - vehicle.gravity) * env.scenario.dt
    assert vertical_speed == pytest.approx(expected, rel=1e-12)
    np.testing.assert_allclose(info["rotor_thrusts"], vehicle.max_rotor_thrust)


def test_out_of_range_actions_are_clipped_and_non_finite_ones_rejected():
    a, b = QuadrotorEnv("hover-calm"), QuadrotorEnv("hover-calm")
    a.reset(seed=1), b.reset(seed=1)
    assert np.array_equal(a.step(np.array([5.0, -9.0, 0.2, 1.0]))[0],
                          b.step(np.array([1.0, -1.0, 0.2, 1.0]))[0])
    with pytest.raises(ValueError, match="actions must be finite"):
        a.step(np.array([np.nan, 0, 0, 0]))
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        a.step(np.zeros(3))
    with pytest.raises(ValueError, match="numeric"):
        a.step("up")


def test_six_d_rotation_observation_is_the_first_two_columns():
    env = QuadrotorEnv("hover-calm", rotation_representation="6d")
    obs, _ = env.reset(seed=3)
    assert obs.shape == (21,) and env.observation_space.shape == (21,)
    R = env.core.state.rotation[0]
    np.testing.assert_allclose(obs[6:12], np.concatenate([R[:, 0], R[:, 1]]), atol=1e-7)


def test_observation_layout_matches_the_docstring():
    env = QuadrotorEnv("paper-none")
    obs, info = env.reset(seed=0)
    core = env.core
    np.testing.assert_allclose(obs[0:3], info["position_error"], atol=1e-7)
    np.testing.assert_allclose(obs[0:3], [0.0, 0.0, -0.6], atol=1e-7)  # x(0)=0, x_d(0)=(0,0,0.6)
    np.testing.assert_allclose(obs[6:15], core.state.rotation[0].ravel(), atol=1e-7)
    np.testing.assert_allclose(obs[18:21], info["reference_acceleration"], atol=1e-6)
    np.testing.assert_allclose(obs[21:24], info["reference_heading"], atol=1e-7)
    assert obs.dtype == np.float32


@pytest.mark.parametrize(
    ("scenario", "options", "action", "reason"),
    [
        ("ground-effect-landing", {}, [-1.0, 0, 0, 0], "crashed"),
        ("hover-calm", STILL, [0.3, 0, 0, 0], "out_of_bounds"),
        ("paper-II", {}, [0.0, 0, 0, 0], "attitude_lost"),
        ("hover-calm", {**STILL, "initial_velocity": (1.7e308, 0, 0)}, [0.0, 0, 0, 0],
         "non_finite_state"),
    ],
)
def test_every_termination_has_a_reason_and_a_finite_observation(scenario, options, action,
                                                                 reason):
    env = QuadrotorEnv(scenario, options)
    env.reset(seed=0)
    for _ in range(2000):
        obs, reward, terminated, truncated, info = env.step(np.array(action))
        assert np.all(np.isfinite(obs)) and np.isfinite(reward)
        if terminated or truncated:
            break
    assert terminated and info["termination_reason"] == reason


def test_info_carries_the_true_disturbance_including_ground_effect():
    env = QuadrotorEnv("paper-IIA")
    env.reset(seed=0)
    seen = {}
    for _ in range(800):
        _, _, terminated, _, info = env.step(np.zeros(4))
        seen[round(info["time"], 2)] = info["disturbance_force"]
        if terminated:
            break
    env = QuadrotorEnv("ground-effect-landing")
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(4))
    z = env.core.state.position[0, 2]
    radius = env.scenario.vehicle.rotor_radius
    lift = info["applied_thrust"] * (1 / (1 - 3 * radius / (25 * z)) - 1)
    np.testing.assert_allclose(info["disturbance_force"],
                               lift * env.core.state.rotation[0, :, 2], rtol=1e-12)


def test_paper_iia_disturbance_in_info_switches_at_five_and_seven_seconds():
    env = QuadrotorEnv("paper-IIA", {"vehicle": "paper"}, max_tilt=np.pi, max_body_rate=1e9,
                       max_position_error=1e9)
    env.reset(seed=0)
    forces = {}
    for _ in range(800):
        _, _, _, _, info = env.step(np.zeros(4))
        forces[round(info["time"], 2)] = info["disturbance_force"]
    assert not forces[4.99].any() and not forces[7.0].any()
    np.testing.assert_array_equal(forces[5.0], [1.3, 2.0, 2.6])


def test_info_is_a_fresh_dict_each_step():
    env = QuadrotorEnv("hover-calm")
    env.reset(seed=0)
    first = env.step(np.zeros(4))[4]
    first["reference_position"][:] = 99.0
    second = env.step(np.zeros(4))[4]
    assert first is not second and not np.any(second["reference_position"] == 99.0)


def test_stepping_past_the_time_limit_keeps_a_valid_reference():
    env = QuadrotorEnv("paper-none", {"duration": 0.05})
    env.reset(seed=0)
    for _ in range(20):
        obs, _, _, truncated, info = env.step(np.zeros(4))
    assert truncated and np.all(np.isfinite(obs))
    np.testing.assert_allclose(info["reference_position"][0], 0.4 * 0.2, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"scenario": "paper-3"}, "unknown scenario"),
        ({"action_mode": "rpm"}, "valid: thrust_moments, rotor_thrusts"),
        ({"rotation_representation": "quaternion"}, "valid: matrix, 6d"),
        ({"max_tilt": 4.0}, "max_tilt must be <= pi"),
        ({"reward_position_scale": 0.0}, "position_scale must be > 0"),
        ({"render_mode": "video"}, "render_mode 'video' is not supported; valid: None, human"),
        ({"scenario_options": {"vehicle": "blimp"}}, "unknown vehicle preset"),
    ],
)
def test_bad_env_arguments_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        QuadrotorEnv(**kwargs)


def test_gym_make_passes_the_scenario_through():
    env = gym.make("QuadDOB/Track-v1", scenario="paper-II",
                   scenario_options={"torque_reading": "dx/0.6"})
    assert env.unwrapped.scenario.name == "paper-II"
    assert env.unwrapped.metadata["render_fps"] == 100


def test_thrust_rates_flies_body_rates_through_its_inner_loop():
    from quad_dob_env.envs.actions import MAX_RATE_COMMAND, RATE_GAIN

    env = QuadrotorEnv("paper-none", action_mode="thrust_rates")
    env.reset(seed=0)
    core = env.core
    # one step: the moment it commands is J k_ω (ω_cmd - ω) + ω × J ω, from the equations
    omega = np.array([[0.3, -0.2, 0.1]])
    core.state.angular_velocity[:] = omega
    action = np.array([[0.0, 0.25, -0.5, 0.1]])
    J = core.inertia[0]
    wanted = J @ (RATE_GAIN * (action[0, 1:] * MAX_RATE_COMMAND - omega[0])) + np.cross(
        omega[0], J @ omega[0])
    _, moment = core.action_map.to_command(core.action_map.flown(
        action, core.state.angular_velocity, core.inertia))
    np.testing.assert_allclose(moment[0], wanted, rtol=1e-12, atol=1e-12)
    # held, a rate command is flown: ω settles on it (paper vehicle, wrench actuation)
    env.reset(seed=0)
    for _ in range(40):
        env.step(np.array([0.0, 0.0, 0.0, 0.1], np.float32))
    np.testing.assert_allclose(core.state.angular_velocity[0], [0.0, 0.0, 0.4], atol=1e-3)
    with pytest.raises(ValueError, match="thrust_rates' is for direct control only"):
        gym.make("QuadDOB/HoverResidual-v1", action_mode="thrust_rates")


def test_a_start_that_can_be_drawn_below_the_floor_is_refused_and_one_above_it_never_crashes():
    """takeoff-landing-wind starts 0.08 m above its floor: a position noise of 0.12 m drew a
    fifth of its starts below it, reported as a crash by reset (issue 57)."""
    with pytest.raises(ValueError, match=r"initial_position_noise 0\.12 m can start the vehicle "
                                         r"at or below its floor.*a noise below 0\.08 m"):
        gym.make("QuadDOB/TracksResidual-v4", scenario="takeoff-landing-wind",
                 scenario_options={"initial_position_noise": 0.12})
    env = gym.make("QuadDOB/TracksResidual-v4", scenario="takeoff-landing-wind",
                   scenario_options={"initial_position_noise": 0.079})
    for seed in range(40):
        _, info = env.reset(seed=seed)
        assert "termination_reason" not in info
        assert env.unwrapped.core.state.position[0, 2] > 0.0


def test_scenario_options_given_as_a_string_are_named():
    with pytest.raises(ValueError, match=r"scenario_options must be a dict of make_scenario's "
                                         r"keywords .* got str 'wind_scale=1\.5'"):
        gym.make("QuadDOB/HoverResidual-v4", scenario_options="wind_scale=1.5")
