"""quad-dob tune: the shipped tuned defaults are what the documented procedure gives."""

import pytest

from quad_dob_baselines import TUNED_GEOMETRIC_GAINS, make_controller
from quad_dob_training import tune
from quad_dob_training.tune import coordinate_descent


def test_the_geometric_gains_descent_gives_the_shipped_gains_and_halves_the_objective():
    # the whole descent of training/tune.py (33 trials on seeds 100-109), as quad-dob tune
    # --controllers geometric-ndob:tuned runs it
    gains, history = coordinate_descent("geometric-ndob:tuned", log=lambda _: None)
    assert gains == TUNED_GEOMETRIC_GAINS
    start, best = history[0]["objective"], min(trial["objective"] for trial in history)
    assert best < 0.5 * start  # 0.0199 m -> 0.0087 m
    controller = make_controller("geometric-ndob:gains-tuned")
    assert controller.name == "geometric-ndob:gains-tuned"
    assert controller.describe()["kx_per_mass"] == [31.36] * 3
    assert controller.describe()["Ks"] == make_controller("geometric-ndob:tuned").describe()["Ks"]


@pytest.mark.parametrize(("controller", "searched"), [
    ("indi", ("filter_bandwidth",)), ("l1", ("force_cutoff", "torque_cutoff"))])
def test_a_reduced_v2_descent_searches_the_estimators_filters_under_their_caps(
        monkeypatch, controller, searched):
    """CI's reduced check of `quad-dob tune --benchmark v2 --controllers indi,l1` (the whole
    search runs by hand): one pass over the filter coordinates alone, on one tuning seed.
    Every candidate keeps its estimator's cap, is judged under the margin first, and the
    winner is at least as good as the start by the descent's own order."""
    monkeypatch.setitem(tune.SEARCHED, controller, searched)
    monkeypatch.setattr(tune, "PASSES", 1)
    monkeypatch.setattr(tune, "EXTRA_PASSES", 0)
    gains, history = coordinate_descent(controller, log=lambda _: None, benchmark="v2",
                                        vehicle="paper", seeds=(100,))
    start = history[0]
    assert start["gains"] == tune.start_gains(controller, "v2", "paper")
    tried = {name: {trial["gains"][name] for trial in history} for name in searched}
    for name in searched:
        assert len(tried[name]) > 1, name  # the coordinate was searched
        assert max(tried[name]) <= tune.BANDWIDTH_CAPS[name], name
    assert all("margin_lost" in trial for trial in history)
    flown = [trial for trial in history if "objective" in trial]
    best = min((trial["margin_lost"], trial["objective"]) for trial in flown)
    chosen = next(trial for trial in flown if trial["gains"] == gains)
    assert chosen["margin_lost"] == best[0] <= start["margin_lost"]
    # within the tie rule's 2 % of the best objective (a slower filter may win a tie)
    assert chosen["objective"] <= best[1] * (1 + tune.TIE_TOLERANCE) ** len(searched)
