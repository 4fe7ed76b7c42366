import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import quad_dob_env  # noqa: F401
from quad_dob_env.envs import QuadrotorEnv, QuadrotorVectorEnv
from quad_dob_training.rl.vec_env import QuadrotorSB3VecEnv

SHORT = {"duration": 0.3}  # 30 steps, so episodes end and autoreset inside the tests


def test_make_vec_gives_the_native_vector_env_with_batched_spaces():
    env = gym.make_vec("QuadDOB/Track-v1", num_envs=6, vectorization_mode="vector_entry_point")
    assert isinstance(env.unwrapped, QuadrotorVectorEnv)
    assert env.observation_space.shape == (6, 24) and env.action_space.shape == (6, 4)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert info["position_error"].shape == (6, 3)
    obs, rewards, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs) and rewards.shape == (6,)


def test_seeding_is_reproducible_and_per_vehicle():
    a, b = (QuadrotorVectorEnv(4, "hover-calm") for _ in range(2))
    obs_a, _ = a.reset(seed=9)
    obs_b, _ = b.reset(seed=9)
    np.testing.assert_array_equal(obs_a, obs_b)
    assert not np.array_equal(obs_a[0], obs_a[1])
    single, _ = QuadrotorEnv("hover-calm").reset(seed=11)
    np.testing.assert_array_equal(obs_a[2], single)  # vehicle i <-> seed + i


def test_vehicles_equal_single_envs_through_next_step_autoresets():
    n, steps = 5, 100
    vector = QuadrotorVectorEnv(n, "gusty-hover", scenario_options=SHORT)
    singles = [QuadrotorEnv("gusty-hover", SHORT) for _ in range(n)]
    obs, _ = vector.reset(seed=100)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(obs[i], env.reset(seed=100 + i)[0])
    pending = [False] * n
    actions = np.random.default_rng(0).uniform(-0.2, 0.2, (steps, n, 4))
    autoresets = 0
    for step in range(steps):
        obs, rewards, terminated, truncated, _ = vector.step(actions[step])
        for i, env in enumerate(singles):
            if pending[i]:  # next-step autoreset: this step resets instead of stepping
                expected, reward, done = env.reset()[0], 0.0, False
                autoresets += 1
            else:
                expected, reward, term, trunc, _ = env.step(actions[step, i])
                done = term or trunc
            np.testing.assert_allclose(obs[i], expected, rtol=0, atol=1e-12)
            assert rewards[i] == pytest.approx(reward, abs=1e-12)
            assert bool(terminated[i] or truncated[i]) == done
            pending[i] = done
    assert autoresets >= n * 2


def test_ended_episodes_report_their_reason():
    vector = QuadrotorVectorEnv(3, "hover-calm", scenario_options=SHORT)
    vector.reset(seed=0)
    for _ in range(30):
        _, _, _, truncated, info = vector.step(np.zeros((3, 4)))
    assert truncated.all() and info["_termination_reason"].all()
    assert list(info["termination_reason"]) == ["time_limit"] * 3


def test_bad_actions_and_order_are_named():
    vector = QuadrotorVectorEnv(3, "hover-calm")
    with pytest.raises(gym.error.ResetNeeded):
        vector.step(np.zeros((3, 4)))
    vector.reset(seed=0)
    actions = np.zeros((3, 4))
    actions[1, 2] = np.nan
    with pytest.raises(ValueError, match=r"envs \[1\]"):
        vector.step(actions)
    with pytest.raises(ValueError, match=r"shape \(3, 4\)"):
        vector.step(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="needs an int or 3 seeds"):
        vector.reset(seed=[1, 2])


def test_sb3_adapter_resets_in_the_same_step_and_keeps_the_terminal_observation():
    venv = QuadrotorSB3VecEnv(3, "hover-calm", seed=0, scenario_options=SHORT)
    first = venv.reset()
    for _ in range(29):
        venv.step(np.zeros((3, 4)))
    obs, rewards, dones, infos = venv.step(np.zeros((3, 4)))
    assert dones.all()
    for i, info in enumerate(infos):
        assert info["TimeLimit.truncated"] and info["termination_reason"] == "time_limit"
        assert not np.array_equal(info["terminal_observation"], obs[i])
    assert obs.shape == first.shape and rewards.dtype == np.float32


def test_ppo_trains_a_few_thousand_steps_on_the_adapter():
    from stable_baselines3 import PPO
    from stable_baselines3.common.logger import Logger

    venv = QuadrotorSB3VecEnv(8, "hover-calm", seed=0)
    model = PPO("MlpPolicy", venv, n_steps=128, batch_size=256, n_epochs=2, seed=0,
                device="cpu", verbose=0)
    model.set_logger(Logger(None, []))  # SB3's default makes an empty /tmp/SB3-* each run
    model.learn(total_timesteps=3072)
    assert model.num_timesteps >= 3072
    action, _ = model.predict(venv.reset(), deterministic=True)
    assert action.shape == (8, 4)


def test_native_vector_env_matches_gymnasiums_sync_vector_env_through_autoresets():
    kwargs = {"scenario": "gusty-hover", "scenario_options": SHORT}
    native = gym.make_vec("QuadDOB/Hover-v1", num_envs=3,
                          vectorization_mode="vector_entry_point", **kwargs)
    reference = gym.make_vec("QuadDOB/Hover-v1", num_envs=3, vectorization_mode="sync",
                             **kwargs)
    assert native.observation_space == reference.observation_space
    assert native.action_space == reference.action_space
    assert native.metadata["autoreset_mode"] == reference.metadata["autoreset_mode"]
    obs, _ = native.reset(seed=21)
    expected, _ = reference.reset(seed=21)
    np.testing.assert_array_equal(obs, expected)
    actions = np.random.default_rng(2).uniform(-0.3, 0.3, (70, 3, 4)).astype(np.float32)
    for action in actions:
        result, expected = native.step(action), reference.step(action)
        for mine, theirs in zip(result[:4], expected[:4], strict=True):
            np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-12)


def _same_info(native: dict, sync: dict, where: str) -> None:
    """Same keys and masks, and the same values wherever a key's mask says the vehicle
    reports it (elsewhere SyncVectorEnv leaves zeros or None)."""
    assert sorted(native) == sorted(sync), (where, sorted(set(native) ^ set(sync)))
    for key, value in native.items():
        other = sync[key]
        if isinstance(value, dict):
            _same_info(value, other, f"{where}/{key}")
        elif key.startswith("_"):
            assert np.array_equal(value, other), f"{where}/{key}"
        else:
            for i in np.flatnonzero(native[f"_{key}"]):
                if value.dtype == object and not isinstance(value[i], str):
                    np.testing.assert_allclose(value[i], other[i], rtol=0, atol=1e-5,
                                               err_msg=f"{where}/{key}[{i}]")
                elif value.dtype == object:
                    assert value[i] == other[i], f"{where}/{key}[{i}]"
                else:
                    np.testing.assert_allclose(value[i], other[i], rtol=0, atol=1e-5,
                                               err_msg=f"{where}/{key}[{i}]")


@pytest.mark.parametrize("env_id", ["QuadDOB/Hover-v1", "QuadDOB/HoverResidual-v1"])
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_info_matches_sync_vector_env_key_for_key_through_autoresets(mode, env_id):
    # randomisation on, so every autoreset draws anew; SyncVectorEnv merges each vehicle's
    # single-env info with Gymnasium's _key masks: the native env must give the same, in
    # both autoreset modes (same-step: final_obs and final_info too)
    options = {"duration": 0.2, "randomization": {"mass": (0.9, 1.1), "drag": (0.8, 1.2)}}
    kwargs = {"num_envs": 3, "scenario": "gusty-hover", "scenario_options": options}
    native = gym.make_vec(env_id, vectorization_mode="vector_entry_point",
                          autoreset_mode=mode, **kwargs)
    sync = gym.make_vec(env_id, vectorization_mode="sync",
                        vector_kwargs={"autoreset_mode": mode}, **kwargs)
    assert native.metadata["autoreset_mode"] is mode
    (obs, info), (obs2, info2) = native.reset(seed=3), sync.reset(seed=3)
    _same_info(info, info2, "reset")
    assert info["_sampled"].all() and "mass" in info["sampled"]
    actions = np.random.default_rng(0).uniform(-0.3, 0.3, (170, 3, 4))
    ends = resampled = named = 0
    for step in range(170):
        obs, rewards, terminated, truncated, info = native.step(actions[step])
        obs2, rewards2, terminated2, truncated2, info2 = sync.step(
            actions[step].astype(np.float32))
        np.testing.assert_allclose(obs, obs2, rtol=0, atol=1e-5)
        np.testing.assert_allclose(rewards, rewards2, rtol=0, atol=1e-5)
        assert np.array_equal(terminated, terminated2) and np.array_equal(truncated, truncated2)
        _same_info(info, info2, f"step {step}")
        resampled += int(info.get("_sampled", np.zeros(3, bool)).sum())
        if "_base_controller" in info:
            named += int(info["_base_controller"].sum())
            assert set(info["base_controller"]["name"][info["_base_controller"]]) == {
                "geometric-ndob:tuned"}
        if step < 169 or mode is AutoresetMode.SAME_STEP:  # next-step: resets a step later
            ends += int((terminated | truncated).sum())
        if mode is AutoresetMode.SAME_STEP and (terminated | truncated).any():
            assert np.array_equal(info["_final_obs"], terminated | truncated)
    assert ends >= 20 and resampled == ends  # every episode end brought fresh draws
    if "Residual" in env_id:  # the base's name comes with every new episode, as sync's
        assert named == resampled


def test_same_step_autoreset_in_a_residual_env_and_a_bad_mode_named():
    envs = gym.make_vec("QuadDOB/HoverResidual-v1", num_envs=2,
                        vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, scenario_options=SHORT)
    obs, _ = envs.reset(seed=0)
    ends = 0
    for _ in range(65):
        obs, rewards, terminated, truncated, info = envs.step(np.zeros((2, 4)))
        assert np.isfinite(obs).all() and np.isfinite(rewards).all()
        if (terminated | truncated).any():
            ends += 1
            assert info["final_obs"][0].shape == obs[0].shape
    assert ends >= 2
    with pytest.raises(ValueError, match="autoreset_mode 'Disabled' is not supported; valid: "
                                         "NextStep, SameStep"):
        QuadrotorVectorEnv(2, autoreset_mode=AutoresetMode.DISABLED)


def test_a_base_controller_on_the_plain_vector_env_builds_the_residual_face_with_a_warning():
    # the residual mode moved to the residual's layer, above the envs (docs/design.md); the
    # old call still flies the same vehicles, and says what to call instead
    from quad_dob_composition import make_base
    from quad_dob_env.residual import ResidualQuadrotorVectorEnv
    from quad_dob_env.scenarios import make_scenario

    vehicle = make_scenario("gusty-hover").vehicle
    with pytest.warns(DeprecationWarning, match="ResidualQuadrotorVectorEnv"):
        old = QuadrotorVectorEnv(2, "gusty-hover", SHORT, base_controller=make_base(
            "geometric-ndob", vehicle), thrust_scale=0.2)
    new = ResidualQuadrotorVectorEnv(2, "gusty-hover", SHORT, thrust_scale=0.2,
                                     base_controller=make_base("geometric-ndob", vehicle))
    assert type(old) is ResidualQuadrotorVectorEnv
    flown = []
    for env in (old, new):
        obs, info = env.reset(seed=3)
        for _ in range(40):  # past the episodes' end: the autoreset plans a base command
            obs, rewards, *_ = env.step(np.full((2, 4), 0.3))
        flown.append((obs, rewards, info["base_controller"]["name"]))
    np.testing.assert_array_equal(flown[0][0], flown[1][0])
    np.testing.assert_array_equal(flown[0][1], flown[1][1])
    assert flown[0][2].tolist() == flown[1][2].tolist() == ["geometric-ndob"] * 2
    with pytest.raises(ValueError, match="unknown keyword argument of QuadrotorVectorEnv "
                                         "'thrust_scale'"):
        QuadrotorVectorEnv(2, "gusty-hover", thrust_scale=0.2)
