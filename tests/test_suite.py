"""quad-dob evaluate --suite: every v1 family, intervals on every score, paired differences."""

import re

import pytest

from quad_dob_training import cli
from quad_dob_training.evaluation.evaluate import SUITES

SUITE = SUITES["v1"]


@pytest.mark.slow
def test_the_suite_flies_every_family_and_writes_a_leaderboard_with_intervals(tmp_path):
    assert cli.main(["evaluate", "--benchmark", "v1", "--suite", "--policies",
                     "geometric-ndob:tuned,geometric", "--seeds", "9001-9003", "--out",
                     str(tmp_path)]) == 0
    board = (tmp_path / "leaderboard.md").read_text()
    for family, scenarios in SUITE.items():
        for scenario in scenarios:
            rows = [line for line in board.splitlines()
                    if line.startswith(f"| {family} | {scenario} |")]
            assert len(rows) == 2, (family, scenario)
            # five scores, each "mean [low, high]" with low <= mean <= high
            for mean, low, high in re.findall(r"([\d.]+) \[([\d.]+), ([\d.]+)\]", rows[1]):
                assert float(low) <= float(mean) <= float(high)
    # every scenario's rows in rank by the one rule (evaluation.ranking)
    for scenarios in SUITE.values():
        for scenario in scenarios:
            (ranking,) = [line for line in board.splitlines()
                          if line.startswith(f"| {scenario} | 1. ")]
            assert " 2. " in ranking and "lost" in ranking
    # geometric without the observer is worse than its tuned NDOB wherever wind or forces act
    summary = next(line for line in board.splitlines() if line.startswith("| geometric |"))
    worse = summary.split("|")[3]
    for scenario in ("dryden-helix-gusts", "gusty-hover", "paper-II"):
        assert scenario in worse


@pytest.mark.slow
def test_a_generalist_trained_a_few_thousand_steps_round_trips_through_the_suite(tmp_path):
    # the generalist's own recipe (acceleration residual, normalised observations), cut to
    # 4096 timesteps: saved, loaded by path, flown over every family, normalisation applied
    from quad_dob_training.learning.train import train
    from quad_dob_training.rl.model_files import load_model
    from quad_dob_training.rl.run_config import resolve_config

    config = resolve_config("ppo", "residual", "QuadDOB/TracksResidual-v1", None, 4096, 32,
                            seed=5)
    config["algo_kwargs"].update(n_steps=64, batch_size=512, n_epochs=1)
    train(config, tmp_path / "run", evaluate_every=10**9, progress_bar=False)
    model, saved = load_model(tmp_path / "run" / "model.zip")
    assert saved["env_kwargs"]["residual_mode"] == "acceleration"
    assert len(saved["observation_normalization"]["mean"]) == model.observation_space.shape[0]
    assert cli.main(["evaluate", "--benchmark", "v1", "--suite", "--policies",
                     f"geometric-ndob:tuned,residual:{tmp_path / 'run' / 'model.zip'}",
                     "--seeds", "9001-9002", "--out", str(tmp_path / "suite")]) == 0
    board = (tmp_path / "suite" / "leaderboard.md").read_text()
    for scenarios in SUITE.values():
        for scenario in scenarios:
            assert f"| {scenario} | residual:run |" in board
