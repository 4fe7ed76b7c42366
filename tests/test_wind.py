import itertools
import math

import numpy as np
import pytest
from gymnasium.utils import seeding

from quad_dob_baselines import make_controller
from quad_dob_env.disturbances import DRYDEN_INTENSITIES, Constant, Dryden, Gust
from quad_dob_env.dynamics import Actuator, VehicleState
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.so3 import exp
from quad_dob_training.evaluation.metrics import flight_metrics
from quad_dob_training.rollout import fly

PAPER = get_vehicle("paper")
DT = 0.01


def simulate_dryden(vehicles=256, steps=8192, **kwargs):
    dryden = Dryden(**kwargs)
    dryden.bind(vehicles, DT)
    dryden.resample(np.arange(vehicles), [np.random.default_rng(s) for s in range(vehicles)])
    grid = np.zeros((vehicles, 3))
    winds = np.empty((steps, vehicles, 3))
    for k in range(steps):
        winds[k] = dryden.evaluate(grid)[2][:, 0]
    return dryden, winds


@pytest.fixture(scope="module")
def moderate_turbulence():
    return simulate_dryden(intensity="moderate", altitude=2.0, direction=0.0, mean_wind=False)


def dryden_psd(frequency, sigma, time_constant, axis):
    """Analytic one-sided Dryden spectra (MIL-F-8785C), each integrating to sigma²."""
    x = 2 * np.pi * frequency * time_constant
    if axis == 0:
        return sigma**2 * 4 * time_constant / (1 + x**2)
    return sigma**2 * 2 * time_constant * (1 + 3 * x**2) / (1 + x**2) ** 2


def test_dryden_variance_matches_sigma_squared_within_5_percent(moderate_turbulence):
    dryden, winds = moderate_turbulence
    variance = np.mean(winds**2, axis=(0, 1))  # zero mean by construction
    np.testing.assert_allclose(variance, dryden.sigmas**2, rtol=0.05)


def test_dryden_spectrum_matches_the_analytic_one_within_10_percent(moderate_turbulence):
    dryden, winds = moderate_turbulence
    steps = winds.shape[0]
    window = np.hanning(steps)
    spectra = np.abs(np.fft.rfft(winds * window[:, None, None], axis=0)) ** 2
    psd = 2 * spectra.mean(axis=1) * DT / np.sum(window**2)  # (F, 3), averaged over vehicles
    frequency = np.fft.rfftfreq(steps, DT)
    edges = np.geomspace(0.1, 10.0, 11)
    for axis in range(3):
        analytic = dryden_psd(frequency, dryden.sigmas[axis], dryden.time_constants()[axis],
                              axis)
        for low, high in itertools.pairwise(edges):
            band = (frequency >= low) & (frequency < high)
            ratio = psd[band, axis].mean() / analytic[band].mean()
            assert abs(ratio - 1) < 0.10, (axis, low, high, ratio)


def test_dryden_scales_follow_mil_f_8785c():
    dryden = Dryden("light", altitude=30 * 0.3048)  # 30 ft
    h = 30.0
    assert dryden.sigmas[2] == pytest.approx(0.1 * DRYDEN_INTENSITIES["light"])
    scale = 0.177 + 0.000823 * h
    assert dryden.sigmas[0] == pytest.approx(dryden.sigmas[2] / scale**0.4)
    np.testing.assert_allclose(dryden.lengths, np.array([h / scale**1.2, h / scale**1.2, h])
                               * 0.3048)
    low = Dryden("light", altitude=0.5)  # below 10 ft the tables' 10 ft apply
    assert low.lengths[2] == pytest.approx(10 * 0.3048)


def test_dryden_mean_wind_blows_along_its_direction():
    dryden, winds = simulate_dryden(vehicles=64, steps=2000, intensity="light",
                                    direction=math.pi / 2)
    mean = winds.mean(axis=(0, 1))
    assert mean[1] == pytest.approx(dryden.mean_speed, rel=0.1)
    assert abs(mean[0]) < 0.1 * dryden.mean_speed


def test_dryden_turbulence_follows_each_vehicles_seed():
    first = Dryden(direction=None)
    first.bind(3, DT)
    first.resample(np.arange(3), [np.random.default_rng(s) for s in (5, 6, 5)])
    winds = np.array([first.evaluate(np.zeros((3, 1)))[2][:, 0] for _ in range(50)])
    np.testing.assert_array_equal(winds[:, 0], winds[:, 2])
    assert not np.allclose(winds[:, 0], winds[:, 1])


def test_gust_is_the_1_cosine_shape():
    gust = Gust(4.0, direction=(0.0, 2.0, 0.0), start=1.0, length=10.0, speed=5.0, hold=0.5)
    t = np.linspace(0, 8, 801)[None, :]
    wind = gust.evaluate(t)[2][0]
    rise, tau = 2.0, t[0] - 1.0
    expected = np.where(tau < 0, 0.0, np.where(
        tau < rise, 2.0 * (1 - np.cos(np.pi * tau / rise)),
        np.where(tau < rise + 0.5, 4.0, np.where(
            tau < 2 * rise + 0.5, 2.0 * (1 + np.cos(np.pi * (tau - rise - 0.5) / rise)), 0.0))))
    np.testing.assert_allclose(wind[:, 1], expected, atol=1e-12)
    assert not wind[:, [0, 2]].any()


def _drag_after_one_step(state, wind, dt=1e-4):
    """The true disturbance the core reports after one short step of ``state`` at hover
    thrust in a constant ``wind``: the drag at the step's end state (no other force)."""
    n = state.n
    scenario = make_scenario("hover-calm", actuation="wrench", drag=True, floor_height=None,
                             initial_position_noise=0.0, initial_attitude_noise=0.0, dt=dt,
                             duration=dt, disturbance=Constant(wind=wind))
    core = QuadrotorBatch(scenario, n)
    core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
    core.state.assign(state)
    core.step(np.zeros((n, 4)))  # hover thrust, no moment
    return core.disturbance_force.copy(), core.state.copy()


def test_drag_opposes_the_air_relative_velocity_and_follows_its_formula():
    rng = np.random.default_rng(2)
    state = VehicleState.at_rest(20, (0.0, 0.0, 1.0))
    state.rotation[:] = exp(rng.normal(size=(20, 3)))
    state.velocity[:] = rng.normal(scale=4.0, size=(20, 3))
    wind = np.array([3.0, -2.0, 1.0])
    state.velocity[0], state.rotation[0] = wind, np.eye(3)  # moving with the air, level
    drag, end = _drag_after_one_step(state, wind)
    relative = end.velocity - wind
    assert np.all(np.einsum("ni,ni->n", drag[1:], relative[1:]) < 0)
    body = np.einsum("nji,nj->ni", end.rotation, relative)
    airspeed = np.linalg.norm(relative, axis=1, keepdims=True)
    expected_body = -(np.array(PAPER.drag_linear)
                      + np.array(PAPER.drag_quadratic) * airspeed) * body
    np.testing.assert_allclose(drag, np.einsum("nij,nj->ni", end.rotation, expected_body),
                               atol=1e-12)
    np.testing.assert_allclose(drag[0], 0.0, atol=1e-12)  # still air, no drag


def test_drag_does_not_depend_on_the_heading_to_the_wind():
    # a vehicle with equal x and y coefficients is round in the horizontal plane: the same
    # 5 m/s wind along body x and at 45 degrees to it must push equally hard
    state = VehicleState.at_rest(2, (0.0, 0.0, 1.0))
    state.rotation[1] = exp(np.array([[0.0, 0.0, np.pi / 4]]))[0]
    drag, _ = _drag_after_one_step(state, np.array([5.0, 0.0, 0.0]))
    push = np.linalg.norm(drag, axis=1)
    assert push[0] == pytest.approx(push[1], rel=1e-12)
    expected = PAPER.drag_linear[0] * 5.0 + PAPER.drag_quadratic[0] * 25.0
    np.testing.assert_allclose(push, [expected, expected], rtol=1e-4)  # v moved in the step


def test_motor_lag_is_an_exact_first_order_response():
    scenario = make_scenario("hover-calm", initial_position_noise=0.0,
                             initial_attitude_noise=0.0, motor_lag=True)
    core = QuadrotorBatch(scenario, 1)
    core.reset(np.zeros(1, dtype=np.intp), [seeding.np_random(0)[0]])
    tau, hover, top = PAPER.motor_time_constant, PAPER.hover_thrust, PAPER.max_total_thrust
    mean_share = tau / DT * (1 - math.exp(-DT / tau))
    for k in range(10):
        core.step(np.array([[1.0, 0.0, 0.0, 0.0]]))
        expected = top + (hover - top) * math.exp(-k * DT / tau) * mean_share
        assert core.applied.thrust[0] == pytest.approx(expected, rel=1e-12)


def test_yaw_is_mixed_last_so_thrust_and_tilt_moments_survive():
    applied = Actuator(PAPER, "rotors").apply([PAPER.hover_thrust], [[1.0, -0.5, 1.0]])
    assert applied.thrust[0] == pytest.approx(PAPER.hover_thrust, rel=1e-12)
    np.testing.assert_allclose(applied.moment[0, :2], [1.0, -0.5], atol=1e-12)
    assert 0 < applied.moment[0, 2] <= 2 * PAPER.torque_coefficient * PAPER.max_rotor_thrust
    assert applied.saturated[0]
    assert applied.rotor_thrusts.min() >= 0 and applied.rotor_thrusts.max() <= 25.0 + 1e-12


NEW_SCENARIOS = ["dryden-helix", "dryden-helix-gusts", "gusty-hover", "takeoff-landing-wind"]


@pytest.mark.slow
def test_geometric_ndob_stays_bounded_in_every_new_scenario():
    # the tuned observer; with the paper's gains it loses 4 of 10 dryden-helix flights
    # (benchmarks/wind_tracking.py), as does the plain geometric controller
    scenarios = [make_scenario(n) for n in NEW_SCENARIOS]
    for seed in range(4):
        for flight in fly(make_controller("geometric-ndob:tuned"), scenarios, seed=seed):
            assert flight.termination_reason == "time_limit", (flight.scenario, seed)
            assert flight_metrics(flight)["rms_position_settled"] < 0.5


def test_a_gust_at_a_random_time_is_the_fixed_gust_at_each_vehicles_drawn_start():
    random_gust = Gust(4.0, direction=(1.0, 0.0, 0.0), start=(0.5, 8.0), length=10.0,
                       speed=10.0, hold=1.0, name="gust_x")
    assert random_gust.is_random and not Gust(4.0).is_random
    random_gust.bind(3, 0.01)
    random_gust.resample(np.arange(3), [np.random.default_rng(s) for s in (1, 2, 1)])
    starts = random_gust.starts
    assert starts[0] == starts[2] != starts[1] and np.all((starts >= 0.5) & (starts <= 8.0))
    assert random_gust.sampled_parameters(1) == {"gust_x_start": starts[1]}
    times = np.tile(np.linspace(0.0, 10.0, 1001), (3, 1))
    wind = random_gust.evaluate(times)[2]
    for i, start in enumerate(starts):
        fixed = Gust(4.0, direction=(1.0, 0.0, 0.0), start=start, length=10.0, speed=10.0,
                     hold=1.0)
        np.testing.assert_array_equal(wind[i], fixed.evaluate(times[i][None])[2][0])
    with pytest.raises(ValueError, match=r"Gust.start range needs low <= high"):
        Gust(4.0, start=(3.0, 1.0))
