"""rl-zoo3 parses, builds and trains every registered id from the project's hyperparameter
files as they are, and enjoy loads the result: the files are in rl-zoo3's schema, not merely
in its style. The ids are the Gymnasium registry's (every ``QuadDOB/`` id that importing
``quad_dob_env`` registers), so an id registered without its entries fails here."""

import argparse
import contextlib
import io
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
import yaml

import quad_dob_env
from quad_dob_training.rl.run_config import HYPERPARAMS, resolve_config

rl_zoo3 = pytest.importorskip("rl_zoo3", reason="rl_zoo3 is a dev dependency")

ENV_IDS = [env_id for env_id in gym.registry if env_id.startswith("QuadDOB/")]
ALGOS = ("ppo", "sac", "td3")
LOOPED = "QuadDOB/TracksResidual-v2"  # an entry whose recipe randomises the loop


def _mode(env_id: str) -> str:
    return "residual" if "Residual" in env_id else "direct"


def _run(monkeypatch, module, arguments: list[str]) -> None:
    monkeypatch.setattr(sys, "argv", [module.__name__, *arguments])
    getattr(module, module.__name__.rsplit(".", 1)[-1])()


def _zoo_envs(algo: str, env_id: str, log_folder, n_envs: int = 2):
    """rl-zoo3's own loader on the shipped file, as ``rl_zoo3.train`` runs it up to the
    model: read, preprocess (schedules, wrappers, normalisation), build ``n_envs`` envs."""
    from rl_zoo3.exp_manager import ExperimentManager

    manager = ExperimentManager(argparse.Namespace(), algo, env_id, str(log_folder),
                                config=str(HYPERPARAMS / f"{algo}.yml"), seed=3, verbose=0)
    with contextlib.redirect_stdout(io.StringIO()):
        hyperparams, saved = manager.read_hyperparameters()
        (hyperparams, manager.env_wrapper, manager.callbacks,
         manager.vec_env_wrapper) = manager._preprocess_hyperparams(hyperparams)
    env = manager.create_envs(n_envs, no_log=True)
    return manager, manager._preprocess_action_noise(hyperparams, saved, env), env


def test_the_registry_holds_every_id_the_package_names():
    named = {*quad_dob_env.ENV_IDS, *quad_dob_env.ENV_IDS_V2, *quad_dob_env.ENV_IDS_V3,
             *quad_dob_env.ENV_IDS_V4}
    assert set(ENV_IDS) == named and len(ENV_IDS) == 17


# the files' batch sizes are for their n_envs, not for the two envs built here
@pytest.mark.filterwarnings("ignore:You have specified a mini-batch size")
@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("algo", ALGOS)
def test_rl_zoo3s_loader_parses_and_builds_every_entry(algo, env_id, tmp_path):
    """Every id has an entry in every algorithm's file that rl-zoo3 reads, builds (the
    training-only env_wrapper included) and hands to the algorithm; and quad-dob train reads
    the same entry into the same env."""
    warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
    from rl_zoo3 import ALGOS as ZOO_ALGOS

    manager, hyperparams, env = _zoo_envs(algo, env_id, tmp_path)
    try:
        observations = env.reset()
        assert observations.shape == (2, *env.observation_space.shape)
        model = ZOO_ALGOS[algo](env=env, seed=3, device="cpu", **hyperparams)
        assert model.observation_space == env.observation_space
        loops = env.get_attr("loop") if manager.env_wrapper is not None else None
    finally:
        env.close()
    config = resolve_config(algo, _mode(env_id), env_id, None, None, None, 3)
    assert config["env_kwargs"].get("benchmark") == gym.spec(env_id).kwargs.get("benchmark")
    entry = yaml.safe_load((HYPERPARAMS / f"{algo}.yml").read_text())[env_id]
    trained = {key: value for key, value in config["env_kwargs"].items()
               if key != "loop_randomization"}
    assert trained == {**gym.spec(env_id).kwargs, **manager.env_kwargs}
    if "loop_randomization" in config["env_kwargs"]:
        # the training-only key is rl-zoo3's env_wrapper, drawn per env: env i, seeded 3 + i,
        # flies group (3 + i) mod groups of its own draw
        assert loops is not None and all(loops)
        (spec,) = entry["env_wrapper"].values()
        assert spec == config["env_kwargs"]["loop_randomization"]
    else:
        assert loops is None and "env_wrapper" not in entry


@pytest.mark.parametrize("env_id", [LOOPED, LOOPED.replace("-v2", "-v3")])
def test_loop_randomization_under_rl_zoo3_flies_the_loop_quad_dob_train_flies(env_id):
    """A single env seeded s flies group s mod groups of draw_loops(spec, s): for s a
    multiple of the groups, group 0 of the draw quad-dob train makes from the same seed, so
    it flies exactly the native run's first vehicle (one source for every equation)."""
    from quad_dob_training.rl.loop_randomization import WRAPPER, LoopRandomization
    from quad_dob_training.rl.vec_env import QuadrotorSB3VecEnv, draw_loops

    warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
    entry = yaml.safe_load((HYPERPARAMS / "ppo.yml").read_text())[env_id]
    spec = entry["env_wrapper"][WRAPPER]
    env = LoopRandomization(gym.make(env_id, **entry["env_kwargs"]), **spec)
    assert env.loop is None
    observation, _ = env.reset(seed=8)
    config = resolve_config("ppo", "residual", env_id, None, None, None, 8)
    kwargs = dict(config["env_kwargs"])
    native = QuadrotorSB3VecEnv(4, kwargs.pop("scenario"), seed=8, **kwargs)
    assert env.loop == native.loops[0]
    assert np.array_equal(observation, native.reset()[0])
    rng = np.random.default_rng(0)
    for _ in range(50):
        actions = rng.uniform(-1.0, 1.0, (4, *env.action_space.shape)).astype(np.float32)
        observation, reward, *_ = env.step(actions[0])
        observations, rewards, _, _ = native.step(actions)
        assert np.array_equal(observation, observations[0]) and reward == rewards[0]
    # a reset without a seed keeps the loop; another seed draws its own
    flown = env.loop
    env.reset()
    assert env.loop == flown
    env.reset(seed=5)
    assert env.loop == draw_loops(spec, 5, 0.01)[5 % spec["groups"]]
    env.close()
    native.close()


def test_loop_randomizations_wrapper_and_its_quad_dob_train_form_are_checked():
    from quad_dob_training.rl.loop_randomization import (
        WRAPPER,
        LoopRandomization,
        training_options,
    )

    spec = {"groups": 2, "vehicle": ["paper"]}
    assert (training_options({WRAPPER: spec}, "f") == training_options([{WRAPPER: spec}], "f")
            == {"loop_randomization": spec})
    assert training_options(WRAPPER, "f") == {"loop_randomization": {}}
    with pytest.raises(ValueError, match=r"takes only quad_dob_training.rl.loop_randomization"):
        training_options(["rl_zoo3.wrappers.TimeFeatureWrapper"], "f")
    with pytest.raises(ValueError, match=r"loop_randomization key in f 'group'"):
        training_options({WRAPPER: {"group": 2}}, "f")
    with pytest.raises(ValueError, match=r"loop_randomization key 'group'"):
        LoopRandomization(gym.make("QuadDOB/HoverResidual-v3"), group=2)
    with pytest.raises(ValueError, match=r"must be the first env_wrapper.*TimeLimit"):
        LoopRandomization(gym.wrappers.TimeLimit(gym.make("QuadDOB/HoverResidual-v3"), 10))


def test_quad_dob_train_refuses_the_key_given_twice_and_other_wrappers(tmp_path):
    from quad_dob_training.rl.loop_randomization import WRAPPER

    entry = yaml.safe_load((HYPERPARAMS / "ppo.yml").read_text())[LOOPED]
    (spec,) = entry["env_wrapper"].values()
    conf = tmp_path / "ppo.yml"
    conf.write_text(yaml.safe_dump({LOOPED: {
        **entry, "env_kwargs": {**entry["env_kwargs"], "loop_randomization": spec}}}))
    with pytest.raises(ValueError, match=r"loop_randomization in ppo.yml .* given twice"):
        resolve_config("ppo", "residual", LOOPED, None, None, None, 0, hyperparams=conf)
    conf.write_text(yaml.safe_dump({LOOPED: {**entry, "env_wrapper": [
        {WRAPPER: spec}, "rl_zoo3.wrappers.TimeFeatureWrapper"]}}))
    with pytest.raises(ValueError, match=r"env_wrapper in ppo.yml .*TimeFeatureWrapper"):
        resolve_config("ppo", "residual", LOOPED, None, None, None, 0, hyperparams=conf)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rl_zoo3_trains_each_id_from_ppo_yml_and_enjoy_loads_it(env_id, tmp_path, monkeypatch,
                                                               capsys):
    from rl_zoo3 import enjoy, train

    logs = tmp_path / "logs"
    common = ["--algo", "ppo", "--env", env_id, "--gym-packages", "quad_dob_env", "-f",
              str(logs), "--seed", "0"]
    # a thousand steps: the file's n_envs and batch size, shrunk to fit a test's budget
    _run(monkeypatch, train, [*common, "--conf-file", str(HYPERPARAMS / "ppo.yml"),
                              "-n", "1024", "--eval-freq", "-1", "-params", "n_envs:2",
                              "batch_size:64", "n_epochs:1"])
    run = logs / "ppo" / f"{env_id.replace('/', '-')}_1"
    assert (run / f"{env_id.replace('/', '-')}.zip").is_file()
    saved = (run / env_id.replace("/", "-") / "config.yml").read_text()
    assert "env_kwargs" in saved
    capsys.readouterr()
    _run(monkeypatch, enjoy, [*common, "-n", "200", "--no-render", "--exp-id", "1"])
    printed = capsys.readouterr().out
    assert "Loading" in printed and str(run) in printed


@pytest.mark.slow
@pytest.mark.parametrize(("algo", "env_id"), [("sac", "QuadDOB/HoverResidual-v3"),
                                              ("td3", "QuadDOB/Hover-v2")])
def test_rl_zoo3_trains_sac_and_td3_briefly_and_enjoy_loads_them(algo, env_id, tmp_path,
                                                                monkeypatch, capsys):
    from rl_zoo3 import enjoy, train

    logs = tmp_path / "logs"
    common = ["--algo", algo, "--env", env_id, "--gym-packages", "quad_dob_env", "-f",
              str(logs), "--seed", "0"]
    _run(monkeypatch, train, [*common, "--conf-file", str(HYPERPARAMS / f"{algo}.yml"),
                              "-n", "600", "--eval-freq", "-1", "-params", "n_envs:2",
                              "learning_starts:200", "gradient_steps:1", "batch_size:64",
                              "buffer_size:1000"])
    run = logs / algo / f"{env_id.replace('/', '-')}_1"
    assert (run / f"{env_id.replace('/', '-')}.zip").is_file()
    capsys.readouterr()
    _run(monkeypatch, enjoy, [*common, "-n", "100", "--no-render", "--exp-id", "1"])
    assert str(run) in capsys.readouterr().out


@pytest.mark.parametrize("algo", ALGOS)
def test_quad_dob_train_reads_every_entry_of_the_same_files(algo):
    for env_id in ENV_IDS:
        config = resolve_config(algo, _mode(env_id), env_id, None, None, None, 0)
        assert config["env_kwargs"]["scenario"] and config["n_timesteps"] > 0
        # a -v2 or -v3 entry flies its id's benchmark, which the id sets
        assert config["env_kwargs"].get("benchmark") == gym.spec(env_id).kwargs.get(
            "benchmark")
        if "Residual" in env_id:
            assert config["base_controller"] == "geometric-ndob:tuned"
    table = yaml.safe_load((HYPERPARAMS / f"{algo}.yml").read_text())
    assert set(table) == set(ENV_IDS)


@pytest.mark.slow
def test_rl_zoo3_optimize_runs_its_trial_and_writes_its_report(tmp_path, monkeypatch):
    """`python -m rl_zoo3.train ... -optimize` ran its trials, then crashed writing the
    report without pandas (rl-zoo3 lists it only in an extra; the dev extra has it now)."""
    from rl_zoo3 import train

    logs = tmp_path / "logs"
    _run(monkeypatch, train, ["--algo", "ppo", "--env", "QuadDOB/Hover-v1", "--gym-packages",
                              "quad_dob_env", "--conf-file", str(HYPERPARAMS / "ppo.yml"),
                              "-optimize", "--n-trials", "1", "--n-jobs", "1",
                              "--n-timesteps", "512", "--n-startup-trials", "1",
                              "--n-evaluations", "1", "--eval-episodes", "1", "-params",
                              "n_envs:2", "-f", str(logs), "--seed", "0"])
    assert list((logs / "ppo").glob("report_QuadDOB-Hover-v1_1-trials-512-*.csv"))
