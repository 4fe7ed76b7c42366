"""rl-zoo3 trains every id from the project's hyperparameter files as they are, and
enjoy loads the result: the files are in rl-zoo3's schema, not merely in its style."""

import sys
from pathlib import Path

import pytest

import quad_dob_env
from quad_dob_training.rl.run_config import HYPERPARAMS, resolve_config

rl_zoo3 = pytest.importorskip("rl_zoo3", reason="rl_zoo3 is a dev dependency")


def _run(monkeypatch, module, arguments: list[str]) -> None:
    monkeypatch.setattr(sys, "argv", [module.__name__, *arguments])
    getattr(module, module.__name__.rsplit(".", 1)[-1])()


@pytest.mark.slow
@pytest.mark.parametrize("env_id", quad_dob_env.ENV_IDS)
def test_rl_zoo3_trains_each_id_from_ppo_yml_and_enjoy_loads_it(env_id, tmp_path, monkeypatch,
                                                               capsys):
    from rl_zoo3 import enjoy, train

    logs = tmp_path / "logs"
    common = ["--algo", "ppo", "--env", env_id, "--gym-packages", "quad_dob_env", "-f",
              str(logs), "--seed", "0"]
    # a few thousand steps: the file's n_envs and batch size, shrunk to fit a test's budget
    _run(monkeypatch, train, [*common, "--conf-file", str(HYPERPARAMS / "ppo.yml"),
                              "-n", "2048", "--eval-freq", "-1", "-params", "n_envs:4",
                              "batch_size:64", "n_epochs:2"])
    run = logs / "ppo" / f"{env_id.replace('/', '-')}_1"
    assert (run / f"{env_id.replace('/', '-')}.zip").is_file()
    saved = (run / env_id.replace("/", "-") / "config.yml").read_text()
    assert "env_kwargs" in saved
    capsys.readouterr()
    _run(monkeypatch, enjoy, [*common, "-n", "300", "--no-render", "--exp-id", "1"])
    printed = capsys.readouterr().out
    assert "Loading" in printed and str(run) in printed


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_quad_dob_train_reads_every_entry_of_the_same_files(algo):
    for env_id in quad_dob_env.ENV_IDS:
        config = resolve_config(algo, "residual" if "Residual" in env_id else "direct", env_id,
                                None, None, None, 0)
        assert config["env_kwargs"]["scenario"] and config["n_timesteps"] > 0
        if "Residual" in env_id:
            assert config["base_controller"] == "geometric-ndob:tuned"
    assert Path(HYPERPARAMS / f"{algo}.yml").is_file()
    import yaml

    for env_id in yaml.safe_load((HYPERPARAMS / f"{algo}.yml").read_text()):
        if env_id in quad_dob_env.ENV_IDS_V2:  # a v2 entry is held to the same schema
            config = resolve_config(algo, "residual" if "Residual" in env_id else "direct",
                                    env_id, None, None, None, 0)
            assert config["env_kwargs"]["benchmark"] == "v2"


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
