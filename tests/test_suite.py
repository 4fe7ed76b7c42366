"""quad-dob evaluate --suite: every v1 family, intervals on every score, paired differences."""

import re

from quad_dob_training import cli
from quad_dob_training.evaluate import SUITE


def test_the_suite_flies_every_family_and_writes_a_leaderboard_with_intervals(tmp_path):
    assert cli.main(["evaluate", "--suite", "--policies", "geometric-ndob:tuned,geometric",
                     "--seeds", "9001-9003", "--out", str(tmp_path)]) == 0
    board = (tmp_path / "leaderboard.md").read_text()
    for family, scenarios in SUITE.items():
        for scenario in scenarios:
            rows = [line for line in board.splitlines()
                    if line.startswith(f"| {family} | {scenario} |")]
            assert len(rows) == 2, (family, scenario)
            # five scores, each "mean [low, high]" with low <= mean <= high
            for mean, low, high in re.findall(r"([\d.]+) \[([\d.]+), ([\d.]+)\]", rows[1]):
                assert float(low) <= float(mean) <= float(high)
    # geometric without the observer is worse than its tuned NDOB wherever wind or forces act
    summary = next(line for line in board.splitlines() if line.startswith("| geometric |"))
    worse = summary.split("|")[3]
    for scenario in ("dryden-helix-gusts", "gusty-hover", "paper-II"):
        assert scenario in worse
