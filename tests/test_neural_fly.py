"""NF-C (``quad_dob_baselines.neural_fly``) held to Neural-Fly's equations written out here:
the composite law's gains, and the adaptation's discrete update (their supplement §S4,
eqs. 15-19, with the tracking term of their eq. 8), step by step against an oracle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from quad_dob_baselines import make_controller
from quad_dob_baselines.neural_fly import NeuralFlyConstant
from quad_dob_env.params import VEHICLES
from quad_dob_env.sensing import Measurement
from quad_dob_env.trajectories import Reference

VEHICLE = VEHICLES["neural-fly"]
DT = 0.02
E3 = np.array([0.0, 0.0, 1.0])


def _reference(n: int) -> Reference:
    zeros = np.zeros((n, 3))
    return Reference(np.tile([0.0, 0.0, 2.0], (n, 1)), zeros, zeros, zeros, zeros,
                     np.tile([1.0, 0.0, 0.0], (n, 1)), zeros, zeros)


def _tilted(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _oracle(states, thrusts, gains):
    """NF-C's estimate after each step, from the equations (φ = I, P = p I)."""
    m, g = VEHICLE.mass, VEHICLE.gravity
    q, p, lam, rate = (gains["process_noise"], gains["initial_covariance"],
                       gains["forgetting"], gains["composite_rate"])
    r = q / gains["adaptation_rate"] ** 2  # the bandwidth √(q/r)
    a = np.zeros(3)
    out = [a.copy()]
    for k in range(1, len(states)):
        (_, v0, R0), (p1, v1, R1) = states[k - 1], states[k]
        y = m * ((v1 - v0) / DT + g * E3) - thrusts[k - 1] * 0.5 * (R0[:, 2] + R1[:, 2])
        s = v1 + rate * (p1 - np.array([0.0, 0.0, 2.0]))  # the reference is at rest
        a_minus = (1 - lam * DT) * a
        p_minus = (1 - lam * DT) ** 2 * p + q * DT
        k_gain = p_minus / (p_minus + r * DT)
        a = a_minus - k_gain * (a_minus - y) + p_minus * s * DT
        p = (1 - k_gain) ** 2 * p_minus + k_gain**2 * r * DT
        out.append(a.copy())
    return np.array(out)


def test_nf_constants_estimate_is_its_update_written_out():
    gains = {"k_per_mass": 3.0, "composite_rate": 1.5, "process_noise": 0.3,
             "adaptation_rate": 0.4, "initial_covariance": 0.7, "forgetting": 0.05}
    controller = NeuralFlyConstant(**gains)
    controller.reset(1, VEHICLE, DT)
    rng = np.random.default_rng(3)
    states, thrusts, estimates = [], [], []
    for k in range(40):
        state = (np.array([0.1, -0.2, 2.05]) + 0.01 * rng.normal(size=3),
                 0.3 * rng.normal(size=3), _tilted(0.2 * math.sin(0.3 * k)))
        states.append(state)
        measurement = Measurement(state[0][None], state[1][None], state[2][None],
                                  np.zeros((1, 3)))
        controller.compute(np.zeros(1), measurement, _reference(1))
        estimates.append(controller.diagnostics["force_estimate"][0].copy())
        thrust = VEHICLE.hover_thrust * (1.0 + 0.2 * rng.normal())
        thrusts.append(thrust)
        controller.applied(measurement, np.array([thrust]), np.zeros((1, 3)))
    np.testing.assert_allclose(np.array(estimates), _oracle(states, thrusts, gains),
                               rtol=1e-12, atol=1e-12)


def test_a_steady_force_is_learnt_and_the_law_is_lees_with_composite_gains():
    controller = make_controller("nf-constant", VEHICLE, k_per_mass=2.5, composite_rate=2.0,
                                 forgetting=0.0)
    assert controller.gains["kx_per_mass"] == pytest.approx(np.full(3, 2.5 * 2.0))
    assert controller.gains["kv_per_mass"] == pytest.approx(np.full(3, 2.5 + 2.0))
    # level and at rest on the reference (s = 0), told 3 N less thrust than its weight: the
    # measured residual force is 3 N up every step, and without forgetting the estimate,
    # a Kalman filter on it, converges to it
    controller.reset(1, VEHICLE, DT)
    state = Measurement(np.array([[0.0, 0.0, 2.0]]), np.zeros((1, 3)), np.eye(3)[None],
                        np.zeros((1, 3)))
    for _ in range(400):
        controller.compute(np.zeros(1), state, _reference(1))
        controller.applied(state, np.array([VEHICLE.hover_thrust - 3.0]), np.zeros((1, 3)))
    controller.compute(np.zeros(1), state, _reference(1))
    np.testing.assert_allclose(controller.diagnostics["force_estimate"][0], [0.0, 0.0, 3.0],
                               atol=1e-6)
    with pytest.raises(ValueError, match="k_per_mass and composite_rate"):
        NeuralFlyConstant(kx_per_mass=10.0)
    with pytest.raises(ValueError, match="allowed λ Δt < 1"):
        NeuralFlyConstant(forgetting=60.0).reset(1, VEHICLE, DT)


def test_nf_baselines_integral_is_the_composite_error_clamped():
    controller = make_controller("nf-baseline", VEHICLE, k_per_mass=2.0, composite_rate=1.5,
                                 composite_ki_per_mass=4.0, integral_limit_per_weight=0.5)
    assert controller.gains["kx_per_mass"] == pytest.approx(np.full(3, 3.0))
    assert controller.gains["kv_per_mass"] == pytest.approx(np.full(3, 3.5))
    controller.reset(1, VEHICLE, DT)
    m, weight = VEHICLE.mass, VEHICLE.hover_thrust
    position, velocity = np.array([0.3, -0.1, 2.2]), np.array([0.5, 0.2, -0.4])
    state = Measurement(position[None], velocity[None], np.eye(3)[None], np.zeros((1, 3)))
    integral = np.zeros(3)
    limit = 0.5 * weight / (4.0 * m)
    for _ in range(100):
        controller.compute(np.zeros(1), state, _reference(1))
        integral = np.clip(integral + (velocity + 1.5 * (position - [0.0, 0.0, 2.0])) * DT,
                           -limit, limit)
        np.testing.assert_allclose(controller.diagnostics["force_estimate"][0],
                                   4.0 * m * integral, rtol=1e-12)
        controller.applied(state, np.array([weight]), np.zeros((1, 3)))
    assert np.any(np.abs(integral) == limit)  # the clamp was reached


def test_l1_matched_compensates_the_thrust_axis_part_alone():
    """The same L1 flown twice on the same readings: l1-matched's estimate is l1's
    projected on the thrust axis, and its predictor (which takes the whole σ̂) the same."""
    matched = make_controller("l1-matched", VEHICLE)
    # l1-matched's own filter is Neural-Fly's 5 Hz: l1 at the same, to compare the two
    full = make_controller("l1", VEHICLE, force_cutoff=matched.describe()["force_cutoff"])
    assert matched.name == "l1-matched" and matched.compensation == "matched"
    for controller in (full, matched):
        controller.reset(1, VEHICLE, DT)
    rotation = _tilted(0.3)
    for k in range(20):
        state = Measurement(np.array([[0.0, 0.0, 2.0]]),
                            np.array([[0.05 * k, 0.0, -0.02 * k]]), rotation[None],
                            np.zeros((1, 3)))
        for controller in (full, matched):
            controller.compute(np.zeros(1), state, _reference(1))
            controller.applied(state, np.array([VEHICLE.hover_thrust]), np.zeros((1, 3)))
    axis = rotation[:, 2]
    whole = full.diagnostics["force_estimate"][0]
    np.testing.assert_allclose(matched.diagnostics["force_estimate"][0],
                               (whole @ axis) * axis, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(matched.sigma_force, full.sigma_force)
    assert np.linalg.norm(whole - (whole @ axis) * axis) > 0.1  # there was a part to drop
    with pytest.raises(ValueError, match="compensation 'half'; valid: full, matched"):
        make_controller("l1", VEHICLE, compensation="half")


def test_l1_matched_flies_l1s_sets_where_it_has_none_of_its_own():
    from quad_dob_baselines import gain_set

    for benchmark in ("v2", "v3"):
        assert gain_set("l1-matched", benchmark, VEHICLE) == gain_set("l1", benchmark, VEHICLE)
    # v4's own on both vehicles; without them, l1's v4 sets
    assert gain_set("l1-matched", "v4", VEHICLE).tuned_for == ("v4", "neural-fly")
    assert gain_set("l1-matched", "v4", "paper").tuned_for == ("v4", "paper")
    assert gain_set("l1-matched", "v4", "paper") != gain_set("l1", "v4", "paper")


def test_v4s_counterparts_start_from_the_baselines_shared_gains_and_search_their_own():
    """Neural-Fly's methods shared the baseline's P and D and PX4's attitude loop: in v4
    the tunnel's counterparts start from nf-baseline's set, each in its own terms, and the
    search touches only their estimators' values."""
    from quad_dob_baselines import gain_set
    from quad_dob_baselines.neural_fly import lee_gains
    from quad_dob_training.tuning import tune

    base = gain_set("nf-baseline", "v4", "neural-fly").options
    lee = lee_gains(base["k_per_mass"], base["composite_rate"])
    for name in ("l1-matched", "indi-outer"):  # the shipped sets carry the shared gains
        shipped = gain_set(name, "v4", "neural-fly").options
        assert shipped["kx_per_mass"] == pytest.approx(lee["kx_per_mass"], rel=1e-12)
        assert shipped["kv_per_mass"] == pytest.approx(lee["kv_per_mass"], rel=1e-12)
        assert (shipped["kR"], shipped["kOmega"]) == (base["kR"], base["kOmega"])
    assert lee == {"kx_per_mass": base["k_per_mass"] * base["composite_rate"],
                   "kv_per_mass": base["k_per_mass"] + base["composite_rate"]}
    for name, own in (("nf-constant", ("adaptation_rate",)), ("indi-outer", ()),
                      ("l1-matched", ("torque_cutoff", "predictor_rate",
                                      "rotational_predictor_rate"))):
        assert tune.searched_gains(name, "v4") == own
        start = tune.start_gains(name, "v4", "neural-fly")
        assert start["kR"] == base["kR"] and start["kOmega"] == base["kOmega"]
        earlier = gain_set(name, "v3", "neural-fly")
        for key in own:  # its own values from where v3's search left them, where it has one
            if earlier.tuned_for is not None:
                assert start[key] == earlier.options[key], (name, key)
        if name == "nf-constant":
            assert (start["k_per_mass"], start["composite_rate"]) == (
                base["k_per_mass"], base["composite_rate"])
        else:
            assert (start["kx_per_mass"], start["kv_per_mass"]) == (
                lee["kx_per_mass"], lee["kv_per_mass"])
    # their published 5 Hz filters start, and ship, unsearched
    from quad_dob_baselines import make_controller

    for name, key in (("l1-matched", "force_cutoff"), ("indi-outer", "filter_bandwidth")):
        assert tune.start_gains(name, "v4", "neural-fly")[key] == 2 * math.pi * 5.0
        for vehicle in ("neural-fly", "paper"):
            flown = make_controller(name, vehicle, "v4").describe()[key]
            assert flown == pytest.approx(2 * math.pi * 5.0), (name, vehicle)
    # elsewhere, and for the baseline and the classical names, the search is the whole set
    assert tune.searched_gains("indi", "v4") == tune.SEARCHED["indi"]
    assert tune.searched_gains("indi", "v3") == tune.SEARCHED["indi"]
    assert tune.searched_gains("nf-baseline", "v4") == tune.SEARCHED["nf-baseline"]
