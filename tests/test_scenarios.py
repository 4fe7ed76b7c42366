import numpy as np
import pytest

from quad_dob_env.scenarios import PAPER_FORCE, list_scenarios, make_scenario

REQUIRED = ["paper-none", "paper-I", "paper-II", "paper-IIA", "ground-effect-landing",
            "hover-calm", "hover-step-force"]


def test_required_scenarios_are_registered_and_build():
    assert set(REQUIRED) <= set(list_scenarios())
    for name in list_scenarios():
        scenario = make_scenario(name)
        assert scenario.name == name and scenario.steps > 0 and scenario.description


def test_unknown_scenario_lists_the_valid_ones():
    with pytest.raises(ValueError, match=r"valid: .*paper-IIA.*did you mean 'paper-IIA'"):
        make_scenario("paper-IIa")


def test_paper_setup():
    scenario = make_scenario("paper-II")
    assert (scenario.dt, scenario.duration, scenario.steps) == (0.01, 10.0, 1000)
    assert scenario.initial_position == (0.0, 0.0, 0.0)
    np.testing.assert_array_equal(scenario.initial_rotation_matrix(), np.eye(3))
    force, torque, _ = scenario.disturbance.evaluate(np.zeros((1, 1)))
    np.testing.assert_array_equal(force[0, 0], PAPER_FORCE)
    np.testing.assert_allclose(torque[0, 0], 0.6 * np.array(PAPER_FORCE))


def test_both_torque_readings():
    literal = make_scenario("paper-II", torque_reading="dx/0.6")
    _, torque, _ = literal.disturbance.evaluate(np.zeros((1, 1)))
    np.testing.assert_allclose(torque[0, 0], np.array(PAPER_FORCE) / 0.6)
    with pytest.raises(ValueError, match=r"valid: 0\.6\*dx, dx/0\.6"):
        make_scenario("paper-II", torque_reading="0.6")


def test_paper_iia_is_on_from_five_to_seven_seconds():
    scenario = make_scenario("paper-IIA")
    t = np.array([[4.99, 5.0, 6.99, 7.0]])
    force, _, _ = scenario.disturbance.evaluate(t)
    assert np.linalg.norm(force[0], axis=1).astype(bool).tolist() == [False, True, True, False]


@pytest.mark.parametrize("name", ["ground-effect-landing", "takeoff-landing-wind"])
def test_landings_stay_where_the_ground_effect_law_holds(name):
    # the laws are clamped at R/2 above the floor: a landing below it feels a constant factor
    scenario = make_scenario(name)
    times = np.linspace(0.0, scenario.duration, 1001)
    heights = scenario.trajectory.evaluate(times).position[:, 2]
    assert heights.min() > scenario.vehicle.rotor_radius / 2
    assert heights[-1] == pytest.approx(0.08)
    assert scenario.floor_height == 0.0 and scenario.ground_effect is not None


def test_step_force_scales_with_the_vehicle():
    small = make_scenario("hover-step-force", vehicle="crazyflie")
    force, _, _ = small.disturbance.evaluate(np.array([[4.0]]))
    assert force[0, 0, 0] == pytest.approx(0.2 * small.vehicle.hover_thrust)


def test_options_replace_fields_and_bad_ones_are_named():
    fine = make_scenario("paper-I", dt=0.005, substeps=2)
    assert (fine.dt, fine.substeps, fine.steps) == (0.005, 2, 2000)
    with pytest.raises(ValueError, match=r"dt must be >= 0.0001"):
        make_scenario("paper-I", dt=0.0)
    with pytest.raises(ValueError, match=r"substeps must be an integer in \[1, 100\]"):
        make_scenario("paper-I", substeps=0)
    with pytest.raises(ValueError, match=r"unknown option for scenario 'paper-I' 'dtt'.*valid:"):
        make_scenario("paper-I", dtt=0.1)
    with pytest.raises(ValueError, match="valid: ") as refused:
        make_scenario("hover-calm", windd=1.0)
    valid = str(refused.value).split("valid: ")[1].split(", ")
    assert len(valid) == len(set(valid)) and "vehicle" in valid and "dt" in valid
    assert not {"name", "description", "trajectory", "disturbance", "loop"} & set(valid)
    with pytest.raises(ValueError, match="rotation matrix"):
        make_scenario("hover-calm", initial_rotation=np.ones((3, 3)))
    with pytest.raises(ValueError, match="needs a floor"):
        make_scenario("ground-effect-landing", floor_height=None)
