"""The same seed trains the same weights bit for bit, whatever the thread counts the process is
given and whatever else loads the machine (issue 42; the scope: one machine and one set of
library builds)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch
import yaml

from quad_dob_training.rl.model_files import load_model

ENV = "QuadDOB/HoverResidual-v1"
# one rollout of 36,000 is one minibatch: past torch's grain size of 32,768 elements, where a
# reduction split over two threads sums in another order than on one (tests/test_resume.py)
ENTRY = {"env_kwargs": {"scenario": "gusty-hover"}, "n_envs": 60, "n_steps": 600,
         "batch_size": 36_000, "n_epochs": 2, "learning_rate": "lin_0.0003", "gamma": 0.98,
         "n_timesteps": 72_000, "policy_kwargs": {"net_arch": [64, 64]}}
THREAD_VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _training(conf: Path, out: Path, threads: int) -> subprocess.Popen:
    environment = {**os.environ, **{name: str(threads) for name in THREAD_VARIABLES}}
    return subprocess.Popen(
        [sys.executable, "-m", "quad_dob_training.cli", "train", "--env", ENV, "--conf-file",
         str(conf), "--seed", "3", "--evaluate-every", "36000", "--no-progress", "--out",
         str(out)], env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True)


@pytest.mark.slow
def test_one_seed_trains_the_same_weights_on_one_or_two_threads_under_load(tmp_path):
    conf = tmp_path / "ppo.yml"
    conf.write_text(yaml.safe_dump({ENV: ENTRY}))
    # both at once on the 2-core machine: each runs under the other's load
    runs = {threads: tmp_path / f"threads-{threads}" for threads in (1, 2)}
    processes = {threads: _training(conf, out, threads) for threads, out in runs.items()}
    for process in processes.values():
        assert process.wait(timeout=600) == 0, process.stderr.read()
        process.stderr.close()
    first, second = (load_model(out / "model.zip")[0].policy.state_dict()
                     for out in runs.values())
    assert first.keys() == second.keys()
    assert all(torch.equal(first[key], second[key]) for key in first)
    # the evaluations flew the same weights on the same seeds: the same numbers
    assert ((runs[1] / "evaluations.csv").read_text()
            == (runs[2] / "evaluations.csv").read_text())
