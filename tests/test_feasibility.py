"""Feasibility by differential flatness, held to an oracle built from finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from quad_dob_env.feasibility import BENCHMARK_MARGIN, check_reference
from quad_dob_env.flatness import flat_inputs
from quad_dob_env.params import LEE_TORQUE_COEFFICIENT, get_vehicle
from quad_dob_env.scenarios import list_scenarios, make_scenario
from quad_dob_env.trajectories import Circle, Lemniscate, PaperHelix

PAPER = get_vehicle("paper")


def _rd_by_construction(trajectory, times):
    """Rd from the reference alone, as in Lee 2010: b3 along ẍd + g e3, b2 = b3 × b1d."""
    reference = trajectory.evaluate(times)
    thrust_vector = reference.acceleration + np.array([0.0, 0.0, PAPER.gravity])
    b3 = thrust_vector / np.linalg.norm(thrust_vector, axis=1, keepdims=True)
    b2 = np.cross(b3, reference.heading)
    b2 /= np.linalg.norm(b2, axis=1, keepdims=True)
    b1 = np.cross(b2, b3)
    return np.stack([b1, b2, b3], axis=2)


def _vee(matrix):
    return np.stack([matrix[:, 2, 1], matrix[:, 0, 2], matrix[:, 1, 0]], axis=1)


@pytest.mark.parametrize("trajectory", [PaperHelix(), PaperHelix(yaw_rate=0.3),
                                        Circle(radius=1.5, period=4.0), Lemniscate()])
def test_flat_rates_and_moment_match_finite_differences(trajectory):
    times, h = np.linspace(0.3, 4.7, 23), 1e-4
    rd = [_rd_by_construction(trajectory, times + k * h) for k in (-2, -1, 0, 1, 2)]
    # Ωd = vee(Rdᵀ Ṙd), Ṙd by a 4th-order central difference
    rd_dot = (rd[0] - 8 * rd[1] + 8 * rd[3] - rd[4]) / (12 * h)
    rate = _vee(np.swapaxes(rd[2], 1, 2) @ rd_dot)

    def rate_at(offset):
        r = [_rd_by_construction(trajectory, times + offset + k * h) for k in (-1, 1)]
        middle = _rd_by_construction(trajectory, times + offset)
        return _vee(np.swapaxes(middle, 1, 2) @ (r[1] - r[0]) / (2 * h))

    step = 1e-3
    rate_dot = (rate_at(step) - rate_at(-step)) / (2 * step)
    J = PAPER.inertia_matrix
    moment = rate_dot @ J.T + np.cross(rate, rate @ J.T)
    flat = flat_inputs(trajectory.evaluate(times), PAPER.mass, PAPER.gravity, J)
    np.testing.assert_allclose(flat.attitude.rotation, rd[2], atol=1e-12)
    np.testing.assert_allclose(flat.body_rate, rate, atol=1e-6)
    np.testing.assert_allclose(flat.moment, moment, atol=1e-4)
    thrust = PAPER.mass * np.linalg.norm(trajectory.evaluate(times).acceleration
                                         + np.array([0.0, 0.0, PAPER.gravity]), axis=1)
    np.testing.assert_allclose(flat.thrust, thrust, rtol=1e-12)


def test_the_paper_heading_on_lee_rotors_is_refused_naming_the_yaw_axis():
    lee = PAPER.with_changes(torque_coefficient=LEE_TORQUE_COEFFICIENT)
    with pytest.raises(ValueError, match=r"yaw moment \(z\) \[N m\]: needs 0\.5\d+ at t = "
                                         r"[\d.]+ s, limit 0\.04002 .*allow_infeasible"):
        make_scenario("paper-none", vehicle=lee, actuation="rotors")
    built = make_scenario("paper-none", vehicle=lee, actuation="rotors", allow_infeasible=True)
    assert not built.feasibility.feasible
    assert built.feasibility.worst.axis in ("moment_z", "rotors")


def test_the_paper_heading_needs_more_than_even_10_inch_rotors_give():
    # with c = 0.0166 m the yaw fits its own limit, but not together with the helix's
    # thrust and roll: some rotor would have to exceed f_max
    feasibility = check_reference(PaperHelix(), PAPER, "rotors", 10.0, 0.01)
    assert feasibility.margins()["moment_z"] > 0 > feasibility.margins()["rotors"]
    fixed = check_reference(PaperHelix(yaw_rate=0.0), PAPER, "rotors", 10.0, 0.01)
    assert fixed.feasible and fixed.margins()["moment_z"] > 0.99


def test_rotor_row_is_the_mixer_applied_to_the_flat_wrench():
    # hovering in place needs m g shared by four rotors, no moment
    feasibility = check_reference(make_scenario("hover-calm").trajectory, PAPER, "rotors",
                                  1.0, 0.01)
    rotors = {need.axis: need for need in feasibility.needs}["rotors"]
    assert rotors.peak == pytest.approx(abs(PAPER.hover_thrust / 4 - 12.5))
    assert rotors.limit == pytest.approx(PAPER.max_rotor_thrust / 2)


@pytest.mark.parametrize("name", list_scenarios())
def test_every_scenario_is_flyable_with_a_margin(name):
    scenario = make_scenario(name)
    margins = scenario.feasibility.margins()
    assert min(margins.values()) >= BENCHMARK_MARGIN == 0.2, scenario.feasibility.summary()
    if scenario.actuation == "rotors":
        assert "rotors" in margins


def test_a_fast_circle_is_refused_on_thrust():
    # 2 m radius in 1 s: centripetal acceleration 79 m/s², far beyond thrust/weight 2.35
    fast = Circle(radius=2.0, period=1.0)
    with pytest.raises(ValueError, match="collective thrust"):
        make_scenario("hover-calm", trajectory=fast)
    assert math.isfinite(check_reference(fast, PAPER, "rotors", 2.0, 0.01).worst.peak)
