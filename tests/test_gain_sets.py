"""Gains per benchmark and vehicle: a controller's name means the set tuned for where it flies.

v1's names keep v1's gains (v1's tables reproduce); v2's sets were tuned in v2's loop with
the margin, and a test flies every tuning scenario under that margin with each shipped set.
"""

import dataclasses

import numpy as np
import pytest

from quad_dob_baselines import (
    GAIN_SETS,
    MARGIN_LOSSES,
    NonlinearDisturbanceObserver,
    gain_set,
    make_controller,
)
from quad_dob_composition import ResidualVectorEnv
from quad_dob_env.params import get_vehicle
from quad_dob_training import cli
from quad_dob_training.tuning.tune import MARGIN, TUNING_SCENARIOS, TUNING_SEEDS, score

V2_SETS = sorted(key for key in GAIN_SETS if key[1] == "v2")
# each distinct set once (in v2 the two geometric + NDOB names share one)
DISTINCT_V2_SETS = [key for key in V2_SETS
                    if key == next(k for k in V2_SETS if GAIN_SETS[k] is GAIN_SETS[key])]


def test_every_baseline_has_a_v2_set_for_the_paper_and_neural_fly_vehicles():
    for vehicle in ("paper", "neural-fly"):
        for name in ("geometric-ndob:tuned", "geometric-ndob:gains-tuned", "pid", "smc",
                     "geometric-integral", "indi", "l1"):
            assert (name, "v2", vehicle) in GAIN_SETS, (name, vehicle)


@pytest.mark.parametrize("name", ["geometric-ndob:tuned", "geometric-ndob:gains-tuned", "pid",
                                  "smc", "geometric-integral", "geometric", "indi", "l1"])
def test_v1_names_keep_v1_gains(name):
    v1 = make_controller(name, "paper", "v1")
    assert v1.gain_set.tuned_for is None and v1.gain_set.options == {}
    assert _described(v1) == _described(make_controller(name))


@pytest.mark.parametrize("key", V2_SETS, ids=["/".join(key) for key in V2_SETS])
def test_a_v2_name_flies_its_tuned_set(key):
    name, benchmark, vehicle = key
    controller = make_controller(name, vehicle, benchmark)
    assert controller.gain_set.tuned_for == (benchmark, vehicle)
    described = controller.describe()
    for option, value in GAIN_SETS[key].items():
        if option in described:  # the observer's rates show as its gains, checked below
            assert np.allclose(described[option], value), option
    if "translational_rate" in GAIN_SETS[key]:
        rates = {k: GAIN_SETS[key][k] for k in ("translational_rate", "rotational_rate")}
        expected = NonlinearDisturbanceObserver.from_rates(vehicle=get_vehicle(vehicle), **rates)
        assert described["Ks"] == expected.translational_gain
        assert described["Km"] == expected.rotational_gain.tolist()
    # an option given by hand still wins over the set
    nudged = _nudged(GAIN_SETS[key])
    (option, value), = nudged.items()
    given = make_controller(name, vehicle, benchmark, **nudged).describe()
    if option in given:
        assert np.allclose(given[option], value)
    else:  # an observer rate: its gain moves
        assert given["Ks"] != described["Ks"] or given["Km"] != described["Km"]


def test_a_vehicle_without_its_own_set_flies_the_paper_vehicles_scaled_to_it():
    chosen = gain_set("pid", "v2", "crazyflie")
    assert chosen.tuned_for == ("v2", "paper") and chosen.scaled
    assert chosen.options == GAIN_SETS[("pid", "v2", "paper")]  # per mass and inertia already
    crazyflie, paper = get_vehicle("crazyflie"), get_vehicle("paper")
    inertia = np.trace(crazyflie.inertia_matrix) / np.trace(paper.inertia_matrix)
    geometric = gain_set("geometric-ndob:tuned", "v2", "crazyflie").options
    own = GAIN_SETS[("geometric-ndob:tuned", "v2", "paper")]
    assert geometric["kR"] == pytest.approx(own["kR"] * inertia)
    assert geometric["kOmega"] == pytest.approx(own["kOmega"] * inertia)
    assert geometric["kx_per_mass"] == own["kx_per_mass"]
    smc = gain_set("smc", "v2", "crazyflie").options
    assert smc["disturbance_bound"] == pytest.approx(
        GAIN_SETS[("smc", "v2", "paper")]["disturbance_bound"] * crazyflie.mass / paper.mass)
    # looked up by name: a renamed copy of Neural-Fly's vehicle is another vehicle
    renamed = dataclasses.replace(get_vehicle("neural-fly"), name="nf-custom")
    assert gain_set("pid", "v2", renamed).tuned_for == ("v2", "paper")
    with pytest.raises(ValueError, match="benchmark"):
        gain_set("pid", "v5", "paper")


def test_the_paper_observer_preset_refuses_rates():
    with pytest.raises(ValueError, match="geometric-ndob:tuned"):
        make_controller("geometric-ndob", translational_rate=80.0)


@pytest.mark.slow
def test_a_residual_models_base_flies_the_gains_it_was_trained_with():
    from quad_dob_training.policies import make_policy

    shipped = make_policy("residual")
    assert shipped.base_benchmark == "v1"  # trained on TracksResidual-v1
    env = ResidualVectorEnv(2, "gusty-hover", benchmark="v2", **shipped.env_kwargs())
    assert env.residual.controller.gain_set.tuned_for is None  # v1's, in v2's loop
    assert env.core.scenario.loop.inner_rate == 200.0
    env.close()


def test_the_envs_build_their_base_with_the_scenarios_benchmark_and_vehicle():
    for benchmark, expected in (("v1", None), ("v2", ("v2", "paper"))):
        env = ResidualVectorEnv(2, "hover-calm", benchmark=benchmark,
                                base_controller="geometric-ndob:tuned")
        assert env.residual.controller.gain_set.tuned_for == expected
        env.close()
    env = ResidualVectorEnv(2, "figure8-wind-0", benchmark="v2", base_controller="pid")
    assert env.residual.controller.gain_set.tuned_for == ("v2", "neural-fly")
    env.close()


@pytest.mark.slow
@pytest.mark.parametrize("key", DISTINCT_V2_SETS, ids=["/".join(k) for k in DISTINCT_V2_SETS])
def test_every_shipped_v2_set_keeps_its_tuning_flights_under_the_margin(key):
    """The admissibility the sets were chosen under: every tuning flight (seeds 100-109)
    kept with 10 ms of extra latency and motors 1.5x slower at once; the sets the search
    left short lose exactly the flights ``MARGIN_LOSSES`` declares."""
    name, benchmark, vehicle = key
    result = score(lambda: make_controller(name, vehicle, benchmark), benchmark, vehicle,
                   TUNING_SEEDS, **MARGIN)
    assert result["lost"] == MARGIN_LOSSES.get(key, 0), {
        s: result[s] for s in TUNING_SCENARIOS[benchmark]}


def test_the_command_line_names_what_disagrees(capsys):
    with pytest.raises(SystemExit):
        cli.main(["evaluate", "--benchmark", "v1", "--scenario-option", "benchmark=v2",
                  "--seeds", "1", "--out", "/tmp/quad-dob-unused"])
    assert "disagree" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["tune", "--vehicle", "hexacopter", "--out", "/tmp/quad-dob-unused"])
    assert "hexacopter" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["tune", "--controllers", "geometric-ndob", "--out", "/tmp/quad-dob-unused"])
    assert "geometric-ndob:tuned" in capsys.readouterr().err


def _described(controller):
    return {key: np.asarray(value).tolist() for key, value in controller.describe().items()}


def _nudged(options):
    first = sorted(options)[0]
    return {first: options[first] * 1.1}


@pytest.mark.slow
def test_the_recommended_base_keeps_every_flight_of_benchmark_v2():
    """v2's own gains on v2's suite (the wind tunnel's strongest wind for the figure-8s):
    no flight lost, the heading held within 0.3 rad, but for helix-force-torque's yaw
    torque, half the hover's yaw authority, which the mixer serves last: no baseline holds
    that heading within 0.2 rad (docs/benchmark-v2.md's table; 0.39 rad here over 20 seeds)."""
    from quad_dob_training.evaluation.evaluate import SUITES, evaluate

    scenarios = [name for names in SUITES["v2"].values() for name in names
                 if not name.startswith("figure8") or name == "figure8-wind-12.1"]
    rows = evaluate(["geometric-ndob:tuned"], scenarios, [9001, 9002, 9003], baseline=None,
                    scenario_options={"benchmark": "v2"})
    assert len(rows) == len(scenarios)
    for row in rows:
        assert row["crashes"] == 0, row["scenario"]
        bound = 0.6 if row["scenario"] == "helix-force-torque" else 0.3
        assert row["rms_heading_settled_mean"] < bound, row["scenario"]
