"""The one rule every ranking uses (issue 56): flights lost first, then the mean RMS error,
a row with no flight scored after one with a score, ties in the order given; and the names
a benchmark's strongest is chosen from."""

import math

import pytest

from quad_dob_baselines import CLASSICAL_NAMES, NEURAL_FLY_LAWS
from quad_dob_training.evaluation.ranking import Standing, beats, candidates, ranked, strongest


def test_flights_lost_rank_before_the_error():
    standings = {"precise-but-lost-one": Standing(1, 0.01), "kept-all": Standing(0, 0.50),
                 "none-scored": Standing(0, math.nan), "also-kept": Standing(0, 0.20)}
    assert ranked(standings) == ["also-kept", "kept-all", "none-scored", "precise-but-lost-one"]
    assert beats(Standing(0, 0.5), Standing(1, 0.01))
    assert not beats(Standing(0, 0.2), Standing(0, 0.2))  # a tie is not a win
    assert ranked({"b": Standing(0, 0.1), "a": Standing(0, 0.1)}) == ["b", "a"]


def test_the_strongest_is_chosen_among_the_benchmarks_classical_names():
    assert candidates("v3") == CLASSICAL_NAMES
    assert candidates("v4") == (*CLASSICAL_NAMES, *NEURAL_FLY_LAWS)
    standings = {name: Standing(0, 0.1 + k / 100) for k, name in enumerate(candidates("v4"))}
    standings["residual"] = Standing(0, 0.01)  # a learned row is ranked, never the strongest
    standings["pid"] = Standing(0, 0.05)
    assert strongest(standings, candidates("v4")) == "pid"
    assert ranked(standings)[0] == "residual"
    with pytest.raises(ValueError, match="not flown: smc"):
        strongest({"pid": Standing(0, 0.1)}, ["pid", "smc"])
    with pytest.raises(ValueError, match="unknown benchmark 'v9'; valid: v1, v2, v3, v4"):
        candidates("v9")
