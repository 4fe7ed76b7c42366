"""quad-dob train killed with SIGKILL and resumed ends with the policy of a run never stopped:
the same weights bit for bit, the same checkpoint names, the same evaluations.csv rows."""

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
import yaml

from quad_dob_training import cli
from quad_dob_training.learning.train import train
from quad_dob_training.rl.checkpoints import latest_checkpoint, load_state
from quad_dob_training.rl.model_files import load_model
from quad_dob_training.rl.run_config import resolve_config

ENV = "QuadDOB/HoverResidual-v1"
TINY = {
    "ppo": {"n_steps": 32, "batch_size": 64, "n_epochs": 2, "learning_rate": "lin_0.0003",
            "gamma": 0.98},
    "sac": {"learning_starts": 256, "buffer_size": 5000, "batch_size": 64, "gradient_steps": 1,
            "train_freq": 1},
}
# Torch splits a reduction over threads only past 32,768 elements (its grain size), and then
# sums in another order on two threads than on one: PPO's advantage normalisation and loss
# means run over the whole minibatch, so a minibatch of 36,000 makes the weights depend on the
# thread count (a resume on two threads differed by 1e-10; the network's size does not matter,
# its matrix products come out the same on any thread count). One rollout is one minibatch.
LARGE = {"n_envs": 60, "n_steps": 600, "batch_size": 36_000, "n_epochs": 2,
         "learning_rate": "lin_0.0003", "gamma": 0.98, "n_timesteps": 108_000,
         "policy_kwargs": {"net_arch": [64, 64]}}
ROLLOUT = 36_000


def _conf_file(tmp_path: Path, algo: str, entry: dict | None = None) -> Path:
    path = tmp_path / f"{algo}.yml"
    entry = entry or {"n_envs": 8, "n_timesteps": 6144,
                      "policy_kwargs": {"net_arch": [32, 32]}, **TINY[algo]}
    path.write_text(yaml.safe_dump({ENV: {"env_kwargs": {"scenario": "gusty-hover"}, **entry}}))
    return path


def _train_arguments(conf: Path, out: Path) -> list[str]:
    return ["train", "--env", ENV, "--conf-file", str(conf), "--seed", "5",
            "--checkpoint-every", str(ROLLOUT), "--evaluate-every", "18000", "--no-progress",
            "--out", str(out)]


def _cli(*arguments: str) -> list[str]:
    return [sys.executable, "-m", "quad_dob_training.cli", *arguments]


def _same_weights(a: Path, b: Path) -> bool:
    first, second = load_model(a)[0].policy.state_dict(), load_model(b)[0].policy.state_dict()
    return first.keys() == second.keys() and all(torch.equal(first[k], second[k])
                                                 for k in first)


def _evaluated_timesteps(run: Path) -> list[int]:
    path = run / "evaluations.csv"
    if not path.is_file():  # written by rename: a file there is whole
        return []
    with open(path, newline="") as file:
        return [int(row["timesteps"]) for row in csv.DictReader(file)]


def _checkpoint_steps(run: Path) -> list[int]:
    return sorted(int(p.stem.split("_")[1]) for p in (run / "checkpoints").glob("*.state"))


def _stop_past_a_checkpoint(process: subprocess.Popen, run: Path) -> int:
    """Freeze the run (SIGSTOP: it still holds its lock) once it has a checkpoint and has
    evaluated at it (the evaluation runs after the checkpoint is written, at the same
    rollout start), so the resumed run must drop that row and evaluate it again; the newest
    checkpoint's timesteps."""
    deadline = time.monotonic() + 300
    while True:
        assert process.poll() is None and time.monotonic() < deadline, "no checkpoint came"
        steps = _checkpoint_steps(run)
        if steps and max(_evaluated_timesteps(run), default=0) >= steps[-1]:
            os.kill(process.pid, signal.SIGSTOP)
            steps = _checkpoint_steps(run)  # checked again: it may have moved on meanwhile
            if max(_evaluated_timesteps(run)) >= steps[-1]:
                return steps[-1]
            os.kill(process.pid, signal.SIGCONT)
        time.sleep(0.02)


@pytest.mark.slow
def test_a_training_killed_mid_run_resumes_in_a_new_process_to_the_same_run(tmp_path, capsys):
    conf = _conf_file(tmp_path, "ppo", LARGE)
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    uninterrupted = subprocess.Popen(_cli(*_train_arguments(conf, whole)),
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     text=True)
    process = subprocess.Popen(_cli(*_train_arguments(conf, killed)),
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        stopped_at = _stop_past_a_checkpoint(process, killed)
        # a second training into the busy folder is refused at once, naming the holder
        with pytest.raises(SystemExit):
            cli.main(_train_arguments(conf, killed))
        refusal = capsys.readouterr().err
        assert f"is in use by another training (pid {process.pid} on" in refusal
        assert "wait for it to finish, or train into another --out" in refusal
    finally:
        os.kill(process.pid, signal.SIGKILL)
        process.wait()
    assert not (killed / "model.zip").exists(), "the run ended before it was killed"
    assert stopped_at < LARGE["n_timesteps"]
    newest = latest_checkpoint(killed)
    assert newest.name == f"ppo_{stopped_at}.state"
    # the dead process's lock file is still there, and is taken over
    assert f'"pid": {process.pid}' in (killed / "run.lock").read_text()
    # the resumed run needs no other option: env, seed, hyperparameters and intervals are
    # the run's own; torch is set up as in a fresh run although nothing is built afresh
    resumed = subprocess.run(_cli("train", "--resume", str(killed), "--no-progress"),
                             check=True, capture_output=True, text=True)
    assert f"resuming {newest}" in resumed.stdout
    assert f"from a run that did not end cleanly (pid {process.pid} on" in resumed.stdout
    assert uninterrupted.wait(timeout=600) == 0, uninterrupted.stderr.read()
    uninterrupted.stderr.close()
    assert load_model(killed / "model.zip")[0].num_timesteps == LARGE["n_timesteps"]
    assert _same_weights(whole / "model.zip", killed / "model.zip")
    assert _same_weights(whole / "best_model.zip", killed / "best_model.zip")
    names = sorted(p.name for p in (whole / "checkpoints").iterdir())
    assert names == ["ppo_36000.state", "ppo_36000.zip", "ppo_72000.state", "ppo_72000.zip"]
    assert sorted(p.name for p in (killed / "checkpoints").iterdir()) == names
    # due every 18,000 timesteps, flown at the rollouts' starts: whole rollouts of 36,000
    assert _evaluated_timesteps(whole) == list(range(0, LARGE["n_timesteps"] + 1, ROLLOUT))
    assert (killed / "evaluations.csv").read_text() == (whole / "evaluations.csv").read_text()
    assert (killed / "run.lock").read_text() == ""  # released cleanly


@pytest.mark.slow
def test_sac_resumes_with_its_replay_buffer_bit_for_bit(tmp_path):
    config = resolve_config("sac", "residual", ENV, None, 1536, 4, seed=2,
                            hyperparams=_conf_file(tmp_path, "sac"))
    options = {"checkpoint_every": 512, "evaluate_every": 10**9, "progress_bar": False}
    train(config, tmp_path / "whole", **options)
    state = tmp_path / "whole" / "checkpoints" / "sac_1024.state"
    assert state.with_name("sac_1024_replay.pkl").is_file()
    train(None, tmp_path / "again", resume=state, progress_bar=False)
    assert _same_weights(tmp_path / "whole" / "model.zip", tmp_path / "again" / "model.zip")


@pytest.mark.slow
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
    assert load_state(earlier)["num_timesteps"] == 512
    model = train(config, tmp_path / "resumed", resume=earlier, progress_bar=False)
    assert model.num_timesteps == 1024
    with pytest.raises(ValueError, match=r"ppo_768\.zip' is not a stable-baselines3 zip"):
        train(config, tmp_path / "resumed2", resume=zip_path, progress_bar=False)
    with pytest.raises(ValueError, match="does not exist"):
        train(config, tmp_path / "x", resume=tmp_path / "nowhere", progress_bar=False)


@pytest.mark.slow
def test_a_run_keeps_its_newest_two_checkpoints_and_no_other_runs_files_are_touched(tmp_path):
    config = resolve_config("ppo", "residual", ENV, None, 1280, 8, seed=3,
                            hyperparams=_conf_file(tmp_path, "ppo"))
    folder = tmp_path / "checkpoints"
    folder.mkdir()
    foreign = [folder / "ppo_64.state", folder / "ppo_64.zip"]  # another run's leftovers
    for path in foreign:
        path.write_bytes(b"not this run's")
    train(config, tmp_path, checkpoint_every=256, evaluate_every=10**9, progress_bar=False)
    # checkpoints were due at 256, 512, 768 and 1024 timesteps: the last two stay
    names = sorted(p.name for p in folder.iterdir())
    assert names == sorted(["ppo_64.state", "ppo_64.zip", "ppo_768.state", "ppo_768.zip",
                            "ppo_1024.state", "ppo_1024.zip"])
    assert all(path.read_bytes() == b"not this run's" for path in foreign)
    assert latest_checkpoint(tmp_path).name == "ppo_1024.state"
    # a later checkpoint of the same run (a branch given up by resuming an earlier one)
    # is not counted among the newest, nor deleted
    for suffix in (".state", ".zip"):
        (folder / f"ppo_1024{suffix}").rename(folder / f"ppo_9984{suffix}")
    train(None, tmp_path, resume=folder / "ppo_768.state", progress_bar=False)
    assert sorted(p.name for p in folder.iterdir()) == sorted(
        ["ppo_64.state", "ppo_64.zip", "ppo_768.state", "ppo_768.zip", "ppo_1024.state",
         "ppo_1024.zip", "ppo_9984.state", "ppo_9984.zip"])
