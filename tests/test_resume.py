"""quad-dob train killed with SIGKILL and resumed ends with the policy of a run never stopped."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
import yaml

from quad_dob_training.checkpoints import latest_checkpoint, load_state
from quad_dob_training.policies import load_model
from quad_dob_training.train import resolve_config, train

ENV = "QuadDOB/HoverResidual-v1"
TINY = {
    "ppo": {"n_steps": 32, "batch_size": 64, "n_epochs": 2, "learning_rate": "lin_0.0003",
            "gamma": 0.98},
    "sac": {"learning_starts": 256, "buffer_size": 5000, "batch_size": 64, "gradient_steps": 1,
            "train_freq": 1},
}


def _conf_file(tmp_path: Path, algo: str) -> Path:
    path = tmp_path / f"{algo}.yml"
    entry = {"env_kwargs": {"scenario": "gusty-hover"}, "n_envs": 8, "n_timesteps": 6144,
             "policy_kwargs": {"net_arch": [32, 32]}, **TINY[algo]}
    path.write_text(yaml.safe_dump({ENV: entry}))
    return path


def _command(conf: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "quad_dob_training.cli", "train", "--env", ENV,
            "--conf-file", str(conf), "--seed", "5", "--checkpoint-every", "1024",
            "--evaluate-every", "100000000", "--no-progress", "--out", str(out), *extra]


def _same_weights(a: Path, b: Path) -> bool:
    first, second = load_model(a)[0].policy.state_dict(), load_model(b)[0].policy.state_dict()
    return first.keys() == second.keys() and all(torch.equal(first[k], second[k])
                                                 for k in first)


def test_a_training_killed_mid_run_resumes_to_the_same_policy_bit_for_bit(tmp_path):
    conf = _conf_file(tmp_path, "ppo")
    subprocess.run(_command(conf, tmp_path / "whole"), check=True, capture_output=True)
    killed = tmp_path / "killed"
    process = subprocess.Popen(_command(conf, killed), stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 240
    while not list((killed / "checkpoints").glob("*_2048.state")):
        assert process.poll() is None and time.monotonic() < deadline, "no checkpoint came"
        time.sleep(0.02)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    assert not (killed / "model.zip").exists(), "the run ended before it was killed"
    newest = latest_checkpoint(killed)
    assert load_state(newest)["num_timesteps"] < 6144
    # the resumed run needs no other option: env, seed and hyperparameters come with it
    resumed = subprocess.run([sys.executable, "-m", "quad_dob_training.cli", "train",
                              "--resume", str(killed), "--no-progress"],
                             check=True, capture_output=True, text=True)
    assert f"resuming {newest}" in resumed.stdout
    assert load_model(killed / "model.zip")[0].num_timesteps == 6144
    assert _same_weights(tmp_path / "whole" / "model.zip", killed / "model.zip")


def test_sac_resumes_with_its_replay_buffer_bit_for_bit(tmp_path):
    config = resolve_config("sac", "residual", ENV, None, 1536, 4, seed=2,
                            hyperparams=_conf_file(tmp_path, "sac"))
    options = {"checkpoint_every": 512, "evaluate_every": 10**9, "progress_bar": False}
    train(config, tmp_path / "whole", **options)
    state = tmp_path / "whole" / "checkpoints" / "sac_1024.state"
    assert state.with_name("sac_1024_replay.pkl").is_file()
    train(config, tmp_path / "again", resume=state, **options)
    assert _same_weights(tmp_path / "whole" / "model.zip", tmp_path / "again" / "model.zip")


def test_a_cut_off_checkpoint_is_named_and_the_earlier_one_still_resumes(tmp_path):
    config = resolve_config("ppo", "residual", ENV, None, 1024, 8, seed=1,
                            hyperparams=_conf_file(tmp_path, "ppo"))
    train(config, tmp_path, checkpoint_every=256, evaluate_every=10**9, progress_bar=False)
    newest = latest_checkpoint(tmp_path)
    newest.write_bytes(newest.read_bytes()[:1000])  # as if the disk filled while writing
    with pytest.raises(ValueError, match=rf"checkpoint state '{newest}' could not be read.*"
                                         "earlier checkpoint"):
        train(config, tmp_path / "resumed", resume=newest, progress_bar=False)
    zip_path = newest.with_suffix(".zip")
    zip_path.write_bytes(zip_path.read_bytes()[:3000])
    newest.unlink()
    earlier = latest_checkpoint(tmp_path)
    assert earlier != newest
    model = train(config, tmp_path / "resumed", resume=earlier, evaluate_every=10**9,
                  progress_bar=False)
    assert model.num_timesteps == 1024
    with pytest.raises(ValueError, match=r"ppo_768\.zip' is not a stable-baselines3 zip"):
        train(config, tmp_path / "resumed2", resume=zip_path, progress_bar=False)
    with pytest.raises(ValueError, match="does not exist"):
        train(config, tmp_path / "x", resume=tmp_path / "nowhere", progress_bar=False)
