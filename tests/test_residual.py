import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import quad_dob_env  # noqa: F401
from quad_dob_baselines import make_controller
from quad_dob_composition import ResidualVectorEnv, residual_command
from quad_dob_env.envs import QuadrotorEnv
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.wrappers import ResidualActionWrapper
from quad_dob_training.rl.vec_env import QuadrotorSB3VecEnv
from quad_dob_training.rollout import fly

SCENARIO, BASE = "dryden-helix-gusts", "geometric-ndob:tuned"
SHORT = {"duration": 0.3}


def test_zero_residual_flies_exactly_the_base_controller():
    env = gym.make("QuadDOB/TrackResidual-v1", scenario=SCENARIO, base_controller=BASE)
    vector = gym.make_vec("QuadDOB/TrackResidual-v1", num_envs=3,
                          vectorization_mode="vector_entry_point", scenario=SCENARIO,
                          base_controller=BASE)
    env.reset(seed=2)
    vector.reset(seed=0)  # vehicle i is seed i
    core, vector_core = env.unwrapped.core, vector.unwrapped.core
    single_path, vector_path = [], []
    for _ in range(400):
        single_path.append(core.state.position[0].copy())
        vector_path.append(vector_core.state.position.copy())
        env.step(np.zeros(4, np.float32))
        vector.step(np.zeros((3, 4)))
    base = fly(make_controller(BASE), [make_scenario(SCENARIO)], seed=2)[0].position[:400]
    np.testing.assert_array_equal(np.array(single_path), base)  # bit for bit
    np.testing.assert_array_equal(np.array(vector_path)[:, 2], base)


def test_residual_adds_its_scaled_share_of_the_limits():
    # wrench actuation: moment limits of 7.9 N m on every axis, far from the base's command
    env = gym.make("QuadDOB/HoverResidual-v1", base_controller="geometric",
                   scenario="hover-calm", scenario_options={"actuation": "wrench"},
                   thrust_scale=0.2,
                   moment_scale=0.05)
    _, info = env.reset(seed=0)
    vehicle = env.unwrapped.core.vehicle
    limit = env.unwrapped.core.actuator.moment_limit
    action = np.array([0.5, -1.0, 0.0, 3.0], np.float32)  # 3.0 is clipped to 1
    _, reward, *_, after = env.step(action)
    applied = env.unwrapped.core.applied
    assert applied.thrust[0] == pytest.approx(info["base_thrust"]
                                              + 0.5 * 0.2 * vehicle.max_total_thrust)
    np.testing.assert_allclose(applied.moment[0], info["base_moment"]
                               + np.array([-0.05, 0.0, 0.05]) * limit, rtol=1e-9, atol=1e-12)
    # the reward charges only the residual's effort (the base's own command is free)
    assert reward == pytest.approx(np.exp(-np.linalg.norm(after["position_error"]) / 0.25)
                                   - 0.01 * np.mean(np.clip(action, -1, 1) ** 2))


def test_residual_observation_carries_the_base_command_and_estimates():
    env = gym.make("QuadDOB/TrackResidual-v1", scenario="paper-II",
                   base_controller=BASE)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (40,) and env.observation_space.contains(obs)
    core = env.unwrapped.core
    for _ in range(100):
        obs, _, _, _, info = env.step(np.zeros(4, np.float32))
    np.testing.assert_allclose(obs[24:28], core.action_map.to_actions(
        info["base_thrust"], info["base_moment"])[0], atol=1e-6)
    vehicle = core.vehicle
    # by 1 s the tuned observer has found paper-II's constant force
    np.testing.assert_allclose(obs[28:31] * vehicle.mass * vehicle.gravity,
                               info["force_estimate"], rtol=1e-5)
    np.testing.assert_allclose(info["force_estimate"], [1.3, 2.0, 2.6], atol=0.05)


def test_residual_envs_pass_the_checkers():
    with pytest.warns(UserWarning, match="different from the unwrapped"):
        check_env(ResidualActionWrapper(QuadrotorEnv("hover-calm"),
                                        make_controller("geometric-ndob:tuned")),
                  skip_render_check=True)
    sb3_check_env(gym.make("QuadDOB/TrackResidual-v1"), warn=False)


def test_vector_residual_equals_single_residual_envs_through_autoresets():
    n, steps = 3, 70
    vector = ResidualVectorEnv(n, "gusty-hover", scenario_options=SHORT,
                               base_controller="geometric-ndob")
    singles = [gym.make("QuadDOB/HoverResidual-v1", scenario="gusty-hover",
                        scenario_options=SHORT, base_controller="geometric-ndob")
               for _ in range(n)]
    obs, _ = vector.reset(seed=5)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(obs[i], env.reset(seed=5 + i)[0])
    actions = np.random.default_rng(1).uniform(-1, 1, (steps, n, 4))
    pending = [False] * n
    for step in range(steps):
        obs, rewards, *_ = vector.step(actions[step])
        for i, env in enumerate(singles):
            if pending[i]:
                expected, reward, done = env.reset()[0], 0.0, False
            else:
                expected, reward, term, trunc, _ = env.step(actions[step, i].astype(np.float32))
                done = term or trunc
            # float32 actions in the single env: residuals agree to float32 rounding
            np.testing.assert_allclose(obs[i], expected, atol=1e-5)
            assert rewards[i] == pytest.approx(reward, abs=1e-6)
            pending[i] = done


@pytest.mark.parametrize(("base", "benchmark"), [
    ("geometric-ndob:tuned", "v1"), ("geometric", "v1"),
    # sensors, estimator and the attitude law at the inner rate: fused_attitude_kernel
    ("geometric-ndob:tuned", "v3"), ("geometric", "v2")])
def test_compiled_residual_pass_equals_the_separate_stages(base, benchmark):
    # the geometric base runs in one compiled pass with the physics
    # (quad_dob_composition.fused); any other controller runs as command -> step -> record
    # -> plan. Both must agree.
    n, steps = 4, 75
    options = {**SHORT, "benchmark": benchmark}
    compiled = ResidualVectorEnv(n, "gusty-hover", scenario_options=options,
                                 base_controller=base)
    staged = ResidualVectorEnv(n, "gusty-hover", scenario_options=options,
                               base_controller=base)
    staged.residual = residual_command(staged.core, base, compiled=False)
    assert compiled.residual._fused is not None and staged.residual._fused is None
    first = [env.reset(seed=3) for env in (compiled, staged)]
    np.testing.assert_array_equal(first[0][0], first[1][0])
    actions = np.random.default_rng(4).uniform(-1.2, 1.2, (steps, n, 4))
    ended = 0
    for step in range(steps):
        (obs, rewards, term, trunc, info), (obs2, rewards2, term2, trunc2, info2) = (
            env.step(actions[step]) for env in (compiled, staged))
        np.testing.assert_allclose(obs, obs2, rtol=0, atol=1e-12)
        np.testing.assert_allclose(rewards, rewards2, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(term, term2)
        np.testing.assert_array_equal(trunc, trunc2)
        for key in ("base_thrust", "base_moment", "force_estimate", "torque_estimate",
                    "applied_moment", "position_error"):
            np.testing.assert_allclose(info[key], info2[key], rtol=0, atol=1e-9, err_msg=key)
        ended += int((term | trunc).sum())
    assert ended >= n  # the comparison ran through autoresets


@pytest.mark.parametrize("n", [4, 300])  # serial, and threaded
def test_what_a_step_returned_stays_as_it_was_after_the_next(n):
    # the compiled pass writes its plan in place every step: what it hands out are copies
    env = ResidualVectorEnv(n, "gusty-hover", base_controller="geometric-ndob:tuned")
    env.reset(seed=0)
    obs, _, _, _, info = env.step(np.zeros((n, 4)))
    kept = {key: np.copy(info[key]) for key in ("base_thrust", "base_moment", "force_estimate",
                                                "torque_estimate", "position_error")}
    kept_obs = obs.copy()
    env.step(np.full((n, 4), 0.5))
    np.testing.assert_array_equal(obs, kept_obs)
    for key, value in kept.items():
        np.testing.assert_array_equal(info[key], value, err_msg=key)


def test_sb3_adapter_runs_in_residual_mode():
    venv = QuadrotorSB3VecEnv(4, "hover-calm", seed=0, base_controller="geometric-ndob",
                              scenario_options=SHORT)
    obs = venv.reset()
    assert obs.shape == (4, 40)
    terminal = []
    for _ in range(40):
        obs, rewards, _, infos = venv.step(np.zeros((4, 4), np.float32))
        assert np.isfinite(obs).all() and np.isfinite(rewards).all()
        terminal += [info["terminal_observation"] for info in infos if info]
    assert len(terminal) == 4 and all(o.shape == (40,) for o in terminal)  # 30-step episodes


def test_bad_base_controller_is_named():
    with pytest.raises(ValueError, match=r"controller 'geometric-dob'.*valid: geometric"):
        gym.make("QuadDOB/TrackResidual-v1", base_controller="geometric-dob")
    with pytest.raises(ValueError, match="thrust_scale"):
        gym.make("QuadDOB/TrackResidual-v1", thrust_scale=0.0)


@pytest.mark.parametrize("env_id", ["QuadDOB/HoverResidual-v1", "QuadDOB/TrackResidual-v1"])
def test_residual_ids_default_to_the_recommended_base_in_wind(env_id):
    env = gym.make(env_id)
    assert env.get_wrapper_attr("residual").controller.name == "geometric-ndob:tuned"
    scenario = env.unwrapped.core.scenario
    assert scenario.loop.drag and scenario.disturbance is not None
    assert "Dryden" in repr(scenario.disturbance)


def test_the_authority_gate_keeps_the_residual_out_where_nothing_disturbs():
    def flight(scenario, residual, gate, compiled=True):
        env = ResidualVectorEnv(2, scenario, compiled=compiled, authority_gate=gate,
                                scenario_options={"duration": 1.0})
        env.reset(seed=3)
        for _ in range(100):
            obs, *_ = env.step(np.full((2, 4), residual))
        return obs, env.residual.gated(np.full((2, 4), residual))

    # calm: the observer sees no disturbance, so any residual flies the base exactly
    assert np.array_equal(flight("paper-none", 0.8, 0.05)[0],
                          flight("paper-none", 0.0, None)[0])
    # a constant push of 0.083 weights: past a gate of 0.05 the residual has all its
    # authority, against a gate of 0.12 part of it (2 * 0.083 / 0.12 - 1 = 0.38)
    assert np.allclose(flight("paper-II", 0.3, 0.05)[1], 0.3, rtol=0, atol=1e-12)
    obs, gated = flight("paper-II", 0.3, 0.12)
    assert np.allclose(gated, 0.3 * (2 * 0.0829 / 0.12 - 1), rtol=0, atol=3e-3)
    assert not np.allclose(obs, flight("paper-II", 0.0, None)[0])
    # the stages and the compiled pass gate alike
    np.testing.assert_allclose(obs, flight("paper-II", 0.3, 0.12, compiled=False)[0],
                               rtol=0, atol=1e-9)
    with pytest.raises(ValueError, match="authority_gate"):
        ResidualVectorEnv(1, "paper-II", authority_gate=-1.0)


def test_an_acceleration_residual_moves_the_equilibrium_by_m_delta_a_over_kx():
    # Oracle from the force law F = -kx ex - kv ev + m g e3 + m (ẍd + Δa) - d̂x: in calm
    # hover a constant Δa settles where kx ex = m Δa, i.e. ex = Δa / 16 with the paper's
    # kx = 16 m, on every axis, and asks for no lasting rotation (Δa is held constant in
    # Ḟ and F̈; fed through ẍd's derivatives instead, x and y settled 2.7x too far)
    env = ResidualVectorEnv(2, "hover-calm", residual_mode="acceleration",
                            acceleration_scale=3.0)
    env.reset(seed=[1, 2])
    residual = np.array([[0.5, 0.0, 0.0, 0.0], [0.0, -0.2, 0.3, 0.0]])
    for _ in range(600):
        obs, *_ = env.step(residual)
    offset = env.core.state.position - env.core.reference.position
    np.testing.assert_allclose(offset, 3.0 * residual[:, :3] / 16.0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(env.core.state.angular_velocity, 0.0, atol=1e-6)
    # the observation's base command is the one flown: the hover thrust, level
    vehicle = env.core.vehicle
    hover = env.core.action_map.to_actions(np.full(2, vehicle.mass * vehicle.gravity),
                                           np.zeros((2, 3)))
    np.testing.assert_allclose(obs[:, 24:28], hover, rtol=0, atol=1e-5)
    # a zero acceleration residual flies the base exactly, as the default mode does
    paths = []
    for mode in ("thrust_moments", "acceleration"):
        env = ResidualVectorEnv(2, SCENARIO, residual_mode=mode,
                                scenario_options={"duration": 1.0})
        env.reset(seed=4)
        for _ in range(100):
            env.step(np.zeros((2, 4)))
        paths.append(env.core.state.position.copy())
    np.testing.assert_array_equal(paths[0], paths[1])


def test_an_acceleration_residual_adds_its_yaw_moment_and_names_what_it_needs():
    env = ResidualVectorEnv(1, "hover-calm", residual_mode="acceleration",
                            scenario_options={"actuation": "wrench"}, moment_scale=0.05)
    env.reset(seed=0)
    env.step(np.array([[0.0, 0.0, 0.0, -2.0]]))  # clipped to -1
    applied = env.core.applied.moment[0, 2]
    np.testing.assert_allclose(applied - env.residual.base_moment[0, 2],
                               -0.05 * env.core.actuator.moment_limit[2], rtol=1e-9)
    assert env.residual.requested_command()[1][0, 2] == pytest.approx(applied)
    with pytest.raises(ValueError, match=r"residual_mode='acceleration' needs a base.*'pid'"):
        ResidualVectorEnv(1, "hover-calm", base_controller="pid", residual_mode="acceleration")
    with pytest.raises(ValueError, match=r"residual_mode 'sideways'.*valid.*acceleration"):
        ResidualVectorEnv(1, "hover-calm", residual_mode="sideways")
    for option, value, message in (("acceleration_scale", 0.0, "must be > 0.0, got 0.0"),
                                   ("vertical_floor", -1.0, "must be >= 0.0, got -1.0")):
        with pytest.raises(ValueError, match=f"residual {option} {message}"):
            ResidualVectorEnv(1, "hover-calm", residual_mode="acceleration", **{option: value})


def test_a_downward_acceleration_residual_stops_at_the_vertical_floor():
    # at the start of a calm hover, on the reference and at rest, the base's desired force
    # is m g e3 (no error, no estimate yet), so the force flown is F_z = m (g + Δa_z),
    # raised to the floor where it would fall below it
    def first_vertical_force(floor):
        env = ResidualVectorEnv(1, "hover-calm", residual_mode="acceleration",
                                acceleration_scale=3.0, vertical_floor=floor,
                                scenario_options={"initial_position_noise": 0.0})
        env.reset(seed=0)
        env.step(np.array([[0.0, 0.0, -1.0, 0.0]]))
        return env.residual.controller.diagnostics["desired_force"][0, 2], env.core.vehicle

    force, vehicle = first_vertical_force(0.0)
    weight = vehicle.mass * vehicle.gravity
    assert force == pytest.approx(vehicle.mass * (vehicle.gravity - 3.0), rel=1e-12)
    assert first_vertical_force(0.5)[0] == pytest.approx(force, rel=1e-12)  # 0.69 g > 0.5 g
    assert first_vertical_force(0.9)[0] == pytest.approx(0.9 * weight, rel=1e-12)
    assert first_vertical_force(1.2)[0] == pytest.approx(weight, rel=1e-12)  # never pushed up


def test_an_acceleration_residual_tilts_the_base_force_by_at_most_20_degrees():
    env = ResidualVectorEnv(2, "hover-calm", residual_mode="acceleration",
                            acceleration_scale=3.0,
                            scenario_options={"initial_position_noise": 0.0})
    env.reset(seed=0)
    # (3, 3) m/s² would tilt m g e3 by 23.4°; (1.5, 0) by 8.7°, which passes untouched
    env.step(np.array([[1.0, 1.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0]]))
    force = env.residual.controller.diagnostics["desired_force"]
    tilt = np.degrees(np.arctan2(np.hypot(force[:, 0], force[:, 1]), force[:, 2]))
    assert tilt[0] == pytest.approx(20.0, rel=1e-9)
    assert force[0, 0] == pytest.approx(force[0, 1], rel=1e-12)  # shortened, not turned
    mass = env.core.vehicle.mass
    assert force[1, 0] == pytest.approx(mass * 1.5, rel=1e-12)
    # the effort term scores what was flown: the shortened residual
    assert env.residual._residual[0, 0] == pytest.approx(
        np.tan(np.radians(20.0)) * env.core.vehicle.gravity / np.sqrt(2) / 3.0, rel=1e-9)


def test_a_residual_id_without_a_base_is_refused_in_every_way_it_is_built():
    # found by tests/fuzzer/: the native vector env read None as direct control
    with pytest.raises(ValueError, match="ResidualVectorEnv needs a base_controller"):
        gym.make_vec("QuadDOB/TracksResidual-v1", num_envs=2,
                     vectorization_mode="vector_entry_point", base_controller=None)
    with pytest.raises(ValueError):
        gym.make("QuadDOB/HoverResidual-v1", base_controller=None)


@pytest.mark.parametrize(("base", "benchmark"), [("geometric-ndob:tuned", "v1"),  # fused
                                                 ("pid", "v1"), ("indi", "v2")])  # stages
def test_the_rate_penalty_is_the_mean_squared_change_of_the_residual_from_the_step_before(
        base, benchmark):
    """reward(w) = reward(0) - w · mean((a_t - a_{t-1})²), a_{-1} = 0 at an episode's start,
    in the compiled pass and in the stages alike; the flight itself does not change."""
    from quad_dob_composition import make_vector_env
    from quad_dob_env import make_scenario

    scenario = make_scenario("gusty-hover", benchmark=benchmark)
    weight = 0.7
    penalised, plain = (make_vector_env(3, scenario, base_controller=base,
                                        residual_rate_weight=w) for w in (weight, 0.0))
    rng = np.random.default_rng(4)
    for _episode in range(2):  # the second starts again from a_{-1} = 0
        for env in (penalised, plain):
            env.reset(seed=[1, 2, 3])
        previous = np.zeros((3, 4))
        for _ in range(25):
            action = rng.uniform(-1, 1, (3, 4))
            obs_a, reward_a, *_ = penalised.step(action)
            obs_b, reward_b, *_ = plain.step(action)
            np.testing.assert_array_equal(obs_a, obs_b)
            expected = weight * np.mean((action - previous) ** 2, axis=1)
            np.testing.assert_allclose(reward_b - reward_a, expected, rtol=1e-12, atol=1e-15)
            previous = action
    with pytest.raises(ValueError, match="residual_rate_weight"):
        make_vector_env(1, scenario, base_controller=base, residual_rate_weight=-1.0)
