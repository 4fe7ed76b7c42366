"""quad-dob tune: the shipped tuned defaults are what the documented procedure gives."""

from quad_dob_baselines import TUNED_GEOMETRIC_GAINS, make_controller
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
