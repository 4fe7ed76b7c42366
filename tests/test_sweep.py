import json
import os
import signal
import subprocess
import sys
import time

import pytest

from quad_dob_training.learning.sweep import finished, load_config, run_sweep, tasks

SMALL = """kind: evaluate
name: small
grid:
  policy: [geometric-ndob]
  scenario: [dryden-helix]
  observer_rate: [2, 10]
  wind_scale: [1.0]
seeds: 0-1
"""


def _lines(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


@pytest.mark.slow
def test_a_local_sweep_and_a_ray_sweep_give_identical_results(tmp_path):
    ray = pytest.importorskip("ray", reason="Ray is the optional [ray] extra")
    config = tmp_path / "small.yaml"
    config.write_text(SMALL)
    local = run_sweep(config, tmp_path / "local", workers=1)
    try:
        on_ray = run_sweep(config, tmp_path / "ray", ray_address="local", workers=2)
    finally:
        ray.shutdown()
    by_id = {r["id"]: r for r in _lines(tmp_path / "local" / "results.jsonl")}
    ray_by_id = {r["id"]: r for r in _lines(tmp_path / "ray" / "results.jsonl")}
    assert by_id == ray_by_id and len(by_id) == 2
    assert local == on_ray
    assert (tmp_path / "local" / "summary.md").exists()


@pytest.mark.slow
def test_a_killed_sweep_resumes_and_runs_every_task_exactly_once(tmp_path):
    config = tmp_path / "six.yaml"
    config.write_text(SMALL.replace("[2, 10]", "[1, 2, 5, 10, 20, 40]"))
    out = tmp_path / "out"
    results = out / "results.jsonl"
    process = subprocess.Popen([sys.executable, "-m", "quad_dob_training.cli", "sweep", str(config),
                                "--out", str(out), "--workers", "1"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                               start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if results.exists() and len(results.read_text().splitlines()) >= 2:
            break
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    before = len(_lines(results))
    assert 1 <= before < 6
    with open(results, "a") as file:  # as if the kill had cut a line in half
        file.write('{"id": "cut-off", "params": {"observ')
    run_sweep(config, out, workers=1)
    ids = [r["id"] for r in _lines(results)]
    assert sorted(ids) == sorted(t["id"] for t in tasks(load_config(config)))
    assert len(ids) == len(set(ids)) == 6
    assert len(finished(results)) == 6


def test_bad_sweep_configs_are_named(tmp_path):
    config = tmp_path / "bad.yaml"
    config.write_text(SMALL.replace("observer_rate", "observer_rat"))
    with pytest.raises(ValueError, match="did you mean 'observer_rate'"):
        load_config(config)
    config.write_text(SMALL + "sed: 3\n")
    with pytest.raises(ValueError, match=r"sweep config key in bad.yaml 'sed'.*seeds"):
        load_config(config)
    config.write_text(SMALL.replace("kind: evaluate", "kind: tune"))
    with pytest.raises(ValueError, match="sweep kind 'tune'"):
        load_config(config)


@pytest.mark.slow
def test_a_training_sweep_trains_and_scores_each_combination(tmp_path):
    config = tmp_path / "train.yaml"
    config.write_text("kind: train\nname: tiny\nenv: QuadDOB/HoverResidual-v1\n"
                      "scenario: hover-calm\ntimesteps: 256\nn_envs: 8\n"
                      "grid:\n  seed: [0, 1]\n  n_steps: [32]\n  batch_size: [64]\n"
                      "seeds: 7-8\n")
    rows = run_sweep(config, tmp_path / "out", workers=1)
    assert [(row["seed"], row["seeds"]) for row in rows] == [(0, 2), (1, 2)]
    assert all(row["rms_position_mean"] < 1.0 for row in rows)


def test_a_shipped_sweep_is_found_from_any_directory(tmp_path, monkeypatch):
    from quad_dob_training.learning.sweep import find_config

    monkeypatch.chdir(tmp_path)  # not the clone's root
    path = find_config("training/sweeps/observer_rate_vs_wind.yaml")
    assert path.is_file() and load_config(path)["kind"] == "evaluate"
    assert find_config("residual_seeds.yaml").is_file()
    with pytest.raises(ValueError, match=r"does not exist; the shipped ones are .*residual_seeds"):
        find_config("training/sweeps/nope.yaml")
