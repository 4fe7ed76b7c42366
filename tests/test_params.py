import dataclasses

import numpy as np
import pytest

from quad_dob_env.params import VEHICLE_SOURCES, VEHICLES, VehicleParams, get_vehicle


def test_paper_preset_matches_the_paper():
    p = get_vehicle("paper")
    assert p.mass == 4.34
    np.testing.assert_array_equal(np.diag(p.inertia_matrix), [0.0820, 0.0845, 0.1377])
    assert p.arm_length == 0.315


def test_paper_yaw_coefficient_is_that_of_a_10_inch_propeller():
    # UIUC APC 10x4.7 static data: C_T = 0.1155, C_P = 0.0474; Q/T = C_P D / (2 pi C_T)
    p = get_vehicle("paper")
    assert p.torque_coefficient == pytest.approx(0.0474 * 0.254 / (2 * np.pi * 0.1155))
    assert 0.015 < p.torque_coefficient < 0.018
    assert p.rotor_radius == pytest.approx(0.254 / 2)


@pytest.mark.parametrize("name", list(VEHICLES))
def test_every_preset_number_has_a_source(name):
    numbers = [f.name for f in dataclasses.fields(VehicleParams)
               if not f.name.startswith("_") and f.name != "name"]
    sources = VEHICLE_SOURCES[name]
    assert sorted(sources) == sorted(numbers)
    assert all(len(text) > 10 for text in sources.values())


@pytest.mark.parametrize("name", list(VEHICLES))
def test_allocation_and_mixer_are_inverse(name):
    p = get_vehicle(name)
    np.testing.assert_allclose(p.allocation_matrix @ p.mixer_matrix, np.eye(4), atol=1e-12)
    # hover: four equal rotors give m g and no moment
    wrench = p.allocation_matrix @ np.full(4, p.hover_thrust / 4)
    np.testing.assert_allclose(wrench, [p.hover_thrust, 0, 0, 0], atol=1e-12)


def test_rotor_moment_arms_follow_the_configuration():
    plus = get_vehicle("paper")
    # plus: rotor 2 sits on +y, so it rolls the vehicle positively by arm * thrust
    assert plus.allocation_matrix[1, 1] == pytest.approx(plus.arm_length)
    x = get_vehicle("crazyflie")
    np.testing.assert_allclose(np.abs(x.allocation_matrix[1]), x.arm_length / np.sqrt(2))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"mass": -1.0}, "mass must be a finite number > 0"),
        ({"mass": float("nan")}, "mass"),
        ({"arm_length": 0.0}, "arm_length"),
        ({"inertia": ((1, 0.5, 0), (0, 1, 0), (0, 0, 1))}, "symmetric"),
        ({"inertia": ((1, 0, 0), (0, -1, 0), (0, 0, 1))}, "positive definite"),
        ({"inertia": ((1, 0, 0), (0, 1, 0), (0, 0, 3))}, "triangle|J1 \\+ J2"),
        ({"max_rotor_thrust": 1.0}, "cannot lift"),
        ({"configuration": "hexa"}, "valid: plus, x"),
    ],
)
def test_bad_parameters_are_rejected_with_the_field_named(change, message):
    with pytest.raises(ValueError, match=message):
        get_vehicle("paper").with_changes(**change)


def test_unknown_preset_and_field_list_the_valid_ones():
    with pytest.raises(ValueError, match="did you mean 'paper'"):
        get_vehicle("papr")
    with pytest.raises(ValueError, match=r"valid: .*mass"):
        get_vehicle("paper").with_changes(weight=3.0)


def test_params_are_frozen_and_hashable():
    p = get_vehicle("paper")
    with pytest.raises(AttributeError):
        p.mass = 1.0
    assert hash(p) == hash(p.with_changes())
    assert isinstance(p, VehicleParams)
