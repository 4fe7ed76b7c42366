"""INDI and L1 adaptive control against their equations written out here (an independent
oracle: the filters from their analog prototypes, the estimates from the dynamics), and in
closed loop: INDI cancels a constant force within a few of its filter's time constants
under ideal and mocap sensing; L1's estimate converges at the rate its adaptation and
predictor set, to the fixed point they set, and its compensation follows at the low-pass
filter's rate; both keep every flight of Benchmark v2's wind scenarios."""

import math

import numpy as np
import oracle
import pytest

from quad_dob_baselines import CONTROLLERS, IncrementalNDI, L1AdaptiveController, make_controller
from quad_dob_baselines.filters import butterworth_lowpass
from quad_dob_baselines.l1 import L1_GAINS, adaptation_gain
from quad_dob_composition import ResidualVectorEnv
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.sensing import Measurement
from quad_dob_env.so3 import exp
from quad_dob_env.trajectories import Reference
from quad_dob_training.rollout import fly

PAPER = get_vehicle("paper")
DT = 0.01
E3 = np.array([0.0, 0.0, 1.0])


def analog_butterworth(bandwidth, dt):
    """H(s) = ω²/(s² + √2 ω s + ω²) with s = c(1 - z⁻¹)/(1 + z⁻¹), c = 2/T, the analog
    cutoff pre-warped to ω_a = c tan(ω T / 2): numerator and denominator in z⁻¹."""
    c = 2.0 / dt
    omega = c * math.tan(bandwidth * dt / 2)
    one_plus, one_minus = np.array([1.0, 1.0]), np.array([1.0, -1.0])
    numerator = omega ** 2 * np.convolve(one_plus, one_plus)
    denominator = (c ** 2 * np.convolve(one_minus, one_minus)
                   + math.sqrt(2) * omega * c * np.convolve(one_minus, one_plus)
                   + omega ** 2 * np.convolve(one_plus, one_plus))
    return numerator / denominator[0], denominator / denominator[0]


def filtered(signal, numerator, denominator):
    """The direct-form difference equation, started at rest on the signal's first value."""
    x = [signal[0]] * 2
    y = [signal[0]] * 2
    out = []
    for value in signal:
        new = (numerator[0] * value + numerator[1] * x[0] + numerator[2] * x[1]
               - denominator[1] * y[0] - denominator[2] * y[1])
        x, y = [value, x[0]], [new, y[0]]
        out.append(new)
    return np.array(out)


@pytest.mark.parametrize("bandwidth", [10.0, 40.0, 150.0])
def test_the_butterworth_section_is_its_analog_prototype_through_the_bilinear_transform(
        bandwidth):
    numerator, denominator = analog_butterworth(bandwidth, DT)
    section = butterworth_lowpass(bandwidth, DT, "test")
    np.testing.assert_allclose(section[:3], numerator, rtol=1e-12)
    np.testing.assert_allclose(section[3:], denominator[1:], rtol=1e-12)
    z = np.exp(-1j * np.array([0.0, bandwidth * DT]))  # DC and the cutoff
    response = np.abs(np.polyval(numerator[::-1], z) / np.polyval(denominator[::-1], z))
    np.testing.assert_allclose(response, [1.0, 1 / math.sqrt(2)], rtol=1e-9)


def test_bad_filter_settings_name_what_is_allowed():
    with pytest.raises(ValueError, match=r"Nyquist rate 314\.2 rad/s"):
        IncrementalNDI(filter_bandwidth=400.0).reset(1, PAPER, DT)
    with pytest.raises(ValueError, match="filter_bandwidth"):
        IncrementalNDI(filter_bandwidth=-1.0)
    with pytest.raises(ValueError, match="force_cutoff"):
        L1AdaptiveController(force_cutoff=0.0)
    with pytest.raises(ValueError, match="unknown"):
        make_controller("l1", gain="x")


def hover_reference(n=1):
    zeros = np.zeros((n, 3))
    heading = np.tile([1.0, 0.0, 0.0], (n, 1))
    return Reference(np.tile([0.0, 0.0, 1.0], (n, 1)), zeros, zeros, zeros, zeros, heading,
                     zeros, zeros)


def synthetic_hover(force, torque, steps):
    """The readings of a level vehicle at hover thrust under a constant world force and a
    body torque about its x axis (a principal axis: no gyroscopic torque), integrated
    exactly: the acceleration and angular acceleration are constant."""
    m, J = PAPER.mass, PAPER.inertia_matrix
    speed = math.sqrt(PAPER.hover_thrust / 4 / PAPER.thrust_coefficient)
    angular_acceleration = np.linalg.solve(J, torque)
    acceleration = force / m
    for k in range(steps):
        t = k * DT
        yield Measurement(np.array([[0.0, 0.0, 1.0]]) + 0.5 * acceleration * t ** 2,
                          (acceleration * t)[None], np.eye(3)[None],
                          (angular_acceleration * t)[None],
                          gyroscope=(angular_acceleration * t)[None],
                          accelerometer=((PAPER.hover_thrust * E3 + force) / m)[None],
                          rotor_speeds=np.full((1, 4), speed))


def test_indi_measures_a_constant_force_and_torque_through_its_filter():
    force, torque = np.array([3.0, -2.0, 1.0]), np.array([0.4, 0.0, 0.0])
    bandwidth = 40.0
    controller = IncrementalNDI(filter_bandwidth=bandwidth)
    controller.reset(1, PAPER, DT)
    estimates = []
    for state in synthetic_hover(force, torque, 60):
        controller.compute(np.zeros(1), state, hover_reference())
        estimates.append(np.concatenate([controller.diagnostics["force_estimate"][0],
                                         controller.diagnostics["torque_estimate"][0]]))
        controller.applied(state, np.array([PAPER.hover_thrust]), np.zeros((1, 3)))
    estimates = np.array(estimates)
    numerator, denominator = analog_butterworth(bandwidth, DT)
    # the force is measured from the first reading; the torque from the first difference
    np.testing.assert_allclose(estimates[:, :3], np.tile(force, (60, 1)), atol=1e-9)
    step = np.r_[0.0, np.ones(59)]
    for k in range(3):
        np.testing.assert_allclose(estimates[:, 3 + k],
                                   torque[k] * filtered(step, numerator, denominator),
                                   atol=1e-9)
    assert abs(estimates[-1, 3] - torque[0]) < 1e-3 * torque[0]


def first_order(signal, bandwidth, dt):
    """ω/(s + ω) discretised exactly for a held input: y_k = p y_{k-1} + (1 - p) x_k with
    the pole p = e^{-ω dt}, started at rest on the signal's first value."""
    pole = math.exp(-bandwidth * dt)
    out, y = [], signal[0]
    for value in signal:
        y = pole * y + (1.0 - pole) * value
        out.append(y)
    return np.array(out)


@pytest.mark.parametrize("loops, filter_order", [("both", 2), ("outer", 1), ("both", 1)])
def test_indi_residuals_are_the_equations_on_arbitrary_readings(loops, filter_order):
    """Tilted and turning, unequal rotor speeds, rates off every principal axis: the
    estimates are the filtered residuals written out here, the allocation from the
    geometry (``oracle.Vehicle``), the gyroscopic torque on the step's mean rate; through
    the Butterworth or a first-order low-pass (``filter_order``). The outer loop alone
    (``loops="outer"``, indi-outer's) leaves the torque estimate at zero."""
    rng = np.random.default_rng(5)
    steps, bandwidth = 40, 60.0
    m, J, k_f = PAPER.mass, PAPER.inertia_matrix, PAPER.thrust_coefficient
    allocation = oracle.Vehicle.of(PAPER).allocation()
    rotations = [exp(0.3 * np.sin(0.1 * k + np.array([0.0, 1.0, 2.0]))) for k in range(steps)]
    rates = [np.array([1.5, -0.8, 0.6]) * np.sin(0.2 * k) + 0.3 for k in range(steps)]
    accelerometers = [np.array([0.4, -0.2, 9.8]) + rng.normal(0, 0.5, 3) for _ in range(steps)]
    speeds = [800.0 + rng.uniform(-60, 60, 4) for _ in range(steps)]
    controller = IncrementalNDI(filter_bandwidth=bandwidth, loops=loops,
                                filter_order=filter_order)
    controller.reset(1, PAPER, DT)
    forces, torques = [], []
    for R, rate, accelerometer, speed in zip(rotations, rates, accelerometers, speeds,
                                             strict=True):
        state = Measurement(np.zeros((1, 3)), np.zeros((1, 3)), R[None], rate[None],
                            gyroscope=rate[None], accelerometer=accelerometer[None],
                            rotor_speeds=speed[None])
        controller.compute(np.zeros(1), state, hover_reference())
        forces.append(controller.force_estimate[0])
        torques.append(controller.torque_estimate[0])
        controller.applied(state, np.array([80.0]), np.zeros((1, 3)))
    wrench = [allocation @ (k_f * speed ** 2) for speed in speeds]
    force_residual = np.array([m * R @ a - w[0] * R[:, 2]
                               for R, a, w in zip(rotations, accelerometers, wrench,
                                                  strict=True)])
    torque_residual = [np.zeros(3)]
    for k in range(1, steps):
        mean = 0.5 * (rates[k] + rates[k - 1])
        torque_residual.append(J @ (rates[k] - rates[k - 1]) / DT + np.cross(mean, J @ mean)
                               - wrench[k][1:])
    torque_residual = np.array(torque_residual)
    if loops == "outer":
        torque_residual[:] = 0.0
    numerator, denominator = analog_butterworth(bandwidth, DT)
    low_pass = ((lambda signal: filtered(signal, numerator, denominator)) if filter_order == 2
                else (lambda signal: first_order(signal, bandwidth, DT)))
    for axis in range(3):
        np.testing.assert_allclose(np.array(forces)[:, axis], low_pass(force_residual[:, axis]),
                                   rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(np.array(torques)[:, axis],
                                   low_pass(torque_residual[:, axis]), rtol=1e-9, atol=1e-9)


def test_indi_outer_is_neural_flys_indi_and_bad_options_name_what_is_allowed():
    from quad_dob_baselines.filters import NEURAL_FLY_FILTER_BANDWIDTH

    outer = make_controller("indi-outer", "neural-fly", "v4")
    assert (outer.name, outer.loops, outer.filter_order) == ("indi-outer", "outer", 1)
    assert outer.filter_bandwidth == pytest.approx(2 * math.pi * 5.0)
    assert outer.filter_bandwidth == NEURAL_FLY_FILTER_BANDWIDTH
    assert outer.actuator_state == "model"  # v4's INDI inputs: no telemetry on their vehicle
    assert make_controller("indi", "neural-fly", "v4").loops == "both"
    with pytest.raises(ValueError, match=r"unknown IncrementalNDI\.loops 'inner'; valid: "
                                         "both, outer"):
        IncrementalNDI(loops="inner")
    with pytest.raises(ValueError, match="filter_order must be one of 1, 2, got 3"):
        IncrementalNDI(filter_order=3)


@pytest.mark.parametrize("benchmark", ["v1", "v2"])  # ideal sensing, mocap in v2's loop
def test_indi_cancels_a_step_of_force_within_a_few_filter_time_constants(benchmark):
    bandwidth = 40.0
    scenario = make_scenario("hover-step-force", initial_position_noise=0.0,
                             initial_attitude_noise=0.0, duration=5.9, benchmark=benchmark)
    assert (scenario.loop.sensing is None) == (benchmark == "v1")
    flight = fly(make_controller("indi", PAPER, "v1", filter_bandwidth=bandwidth), scenario)[0]
    step = 0.2 * PAPER.hover_thrust
    # the record's disturbance is the step's own; the estimate is formed at its start
    error = np.abs(flight.force_estimate[1:, 0] - flight.disturbance_force[:-1, 0]) / step
    onset = int(np.argmax(flight.disturbance_force[:, 0] > 0.5 * step))
    time_constant = 1.0 / bandwidth
    assert error[onset] > 0.5  # the step is news at first
    assert error[onset + round(5 * time_constant / DT)] < 0.05
    assert error[onset + round(10 * time_constant / DT):].max() < 0.01
    # and with the force cancelled the position loop brings the vehicle back
    # (at the geometric law's own pace, ω_n = 4 /s, from the excursion the step made)
    distance = np.linalg.norm(flight.position - flight.reference_position, axis=1)
    assert distance[-1] < 0.3 * distance[onset:].max()


def test_l1_converges_at_its_adaptation_rate_to_its_fixed_point_and_filters_at_its_cutoff():
    force, torque = np.array([3.0, -2.0, 1.0]), np.array([0.4, 0.0, 0.0])
    gains = dict(L1_GAINS)
    controller = L1AdaptiveController(**gains)
    controller.reset(1, PAPER, DT)
    sigma_force, sigma_torque, compensation, torque_compensation = [], [], [], []
    for state in synthetic_hover(force, torque, 80):
        controller.compute(np.zeros(1), state, hover_reference())
        sigma_force.append(controller.sigma_force[0].copy())
        sigma_torque.append(controller.sigma_torque[0].copy())
        compensation.append(controller.diagnostics["force_estimate"][0].copy())
        torque_compensation.append(controller.diagnostics["torque_estimate"][0].copy())
        controller.applied(state, np.array([PAPER.hover_thrust]), np.zeros((1, 3)))
    sigma_force, sigma_torque = np.array(sigma_force), np.array(sigma_torque)
    compensation, torque_compensation = np.array(compensation), np.array(torque_compensation)
    for sigma, disturbance, rate in ((sigma_force, force, gains["predictor_rate"]),
                                     (sigma_torque, torque,
                                      gains["rotational_predictor_rate"])):
        # e_{k+1} = (1 + (a - ρ) dt) e_k - dt d/m (exact for a constant acceleration), so
        # σ̂ = -m ρ e settles at ρ/(ρ - a) d, its error shrinking by |1 + (a - ρ) dt| a step
        a, rho = -rate, adaptation_gain(rate, DT)
        fixed = rho / (rho - a) * disturbance
        np.testing.assert_allclose(sigma[-1], fixed, rtol=1e-9, atol=1e-12)
        assert rho == pytest.approx(a * math.exp(a * DT) / (math.exp(a * DT) - 1))
        np.testing.assert_allclose(fixed, math.exp(a * DT) * disturbance, rtol=1e-12)
        factor = abs(1 + (a - rho) * DT)
        axis = int(np.argmax(np.abs(disturbance)))
        errors = np.abs(sigma[1:6, axis] - fixed[axis])
        np.testing.assert_allclose(errors[1:] / errors[:-1], factor, rtol=1e-6)
    # the compensation follows σ̂'s settled value at the filter's pole e^{-ω dt}
    gaps = np.abs(compensation[10:40, 0] - sigma_force[-1, 0])
    np.testing.assert_allclose(gaps[1:] / gaps[:-1], math.exp(-gains["force_cutoff"] * DT),
                               rtol=1e-6)
    # the torque's: two first-order stages in cascade, y1 <- σ̂Ω, y2 <- y1
    poles = [math.exp(-gains[key] * DT) for key in ("torque_cutoff", "torque_second_cutoff")]
    first = second = np.zeros(3)
    cascade = []
    for k, sigma in enumerate(sigma_torque):
        if k:  # the first step of an episode estimates nothing
            first = poles[0] * first + (1 - poles[0]) * sigma
            second = poles[1] * second + (1 - poles[1]) * first
        cascade.append(second)
    np.testing.assert_allclose(torque_compensation, cascade, rtol=1e-9, atol=1e-12)


def test_l1_compensates_a_step_of_force_in_closed_loop():
    scenario = make_scenario("hover-step-force", initial_position_noise=0.0,
                             initial_attitude_noise=0.0, duration=5.0, benchmark="v1")
    flight = fly(make_controller("l1", PAPER, "v1"), scenario)[0]
    step = 0.2 * PAPER.hover_thrust
    rate = L1_GAINS["predictor_rate"]
    rho = adaptation_gain(rate, DT)
    # a second after the step the estimate sits at the law's fixed point for the force
    estimate = flight.force_estimate[flight.time >= 4.0, 0]
    np.testing.assert_allclose(estimate, rho / (rho + rate) * step, rtol=0.01)
    # and the compensation is subtracted: the vehicle comes back to within the offset the
    # rest of the force, (1 - e^{a dt}) of it, leaves against kx
    offset = (1 - math.exp(-rate * DT)) * step / (16.0 * PAPER.mass)
    distance = np.linalg.norm(flight.position - flight.reference_position, axis=1)
    assert distance[-1] < 0.3 * distance[flight.time >= 3.0].max()
    assert distance[-1] < 3 * offset


@pytest.mark.parametrize("name", ["indi", "l1", "geometric-integral"])
def test_a_residual_base_advances_once_per_step_whatever_restarts_around_it(name):
    """As a residual env's base: 50 finite steps, and restarting one vehicle (which plans
    every vehicle's command again) leaves the others' estimates and commands as they
    were, bit for bit; the restarted one starts with nothing applied."""
    assert name in CONTROLLERS
    env = ResidualVectorEnv(2, "gusty-hover", benchmark="v2", base_controller=name)
    env.reset(seed=3)
    for _ in range(50):
        obs, _, terminated, _, _ = env.step(np.zeros((2, *env.single_action_space.shape)))
    assert np.all(np.isfinite(obs)) and not terminated.any()
    command = env.residual
    controller = command.controller
    assert controller.name == name
    kept = {key: np.copy(value[0]) for key, value in controller.diagnostics.items()}
    base = (np.copy(command.base_thrust[0]), np.copy(command.base_moment[0]))
    env.core.reset(np.array([1]), [np.random.default_rng(11)])
    command.restart(np.array([1]))
    for key, value in kept.items():
        np.testing.assert_array_equal(controller.diagnostics[key][0], value, err_msg=key)
    np.testing.assert_array_equal(command.base_thrust[0], base[0])
    np.testing.assert_array_equal(command.base_moment[0], base[1])
    env.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["indi", "l1"])
def test_indi_and_l1_keep_every_flight_of_the_v2_wind_scenarios(name):
    from quad_dob_training.evaluation.evaluate import SUITES, evaluate

    scenarios = [*SUITES["v2"]["wind"], "figure8-wind-12.1"]
    rows = evaluate([name], scenarios, [9001, 9002, 9003], baseline=None,
                    scenario_options={"benchmark": "v2"})
    assert len(rows) == len(scenarios)
    for row in rows:
        assert row["crashes"] == 0, row["scenario"]
        assert row["rms_position_settled_mean"] < 0.3, row["scenario"]


def test_indi_without_telemetry_reads_a_first_order_model_of_the_command():
    """``actuator_state="model"``: the rotors' state is u_f ← u_f + (1 − e^{−dt/τ})(u_c − u_f)
    on the told wrench u_c, from hover, τ the vehicle's motor time constant; the estimates
    are the filtered residuals against it (the rotor speeds are not read: they carry
    nonsense here). A vehicle whose thrust lags its command exactly so leaves no force."""
    rng = np.random.default_rng(7)
    steps, bandwidth = 40, 60.0
    m, J, tau = PAPER.mass, PAPER.inertia_matrix, PAPER.motor_time_constant
    share = 1.0 - math.exp(-DT / tau)
    commands = [np.r_[PAPER.hover_thrust + rng.uniform(-8, 8), rng.uniform(-0.5, 0.5, 3)]
                for _ in range(steps)]
    model = [np.r_[PAPER.hover_thrust, 0.0, 0.0, 0.0]]  # at the first compute: hover
    for command in commands[:-1]:
        model.append(model[-1] + share * (command - model[-1]))
    rotations = [exp(0.2 * np.sin(0.1 * k + np.array([0.0, 1.0, 2.0]))) for k in range(steps)]
    rates = [np.array([0.5, -0.3, 0.2]) * np.sin(0.3 * k) for k in range(steps)]
    # the accelerometer of a vehicle whose thrust is the model's, and no other force
    accelerometers = [np.array([0.0, 0.0, u[0] / m]) for u in model]
    controller = IncrementalNDI(filter_bandwidth=bandwidth, actuator_state="model")
    controller.reset(1, PAPER, DT)
    forces, torques = [], []
    for R, rate, accelerometer, command in zip(rotations, rates, accelerometers, commands,
                                               strict=True):
        state = Measurement(np.zeros((1, 3)), np.zeros((1, 3)), R[None], rate[None],
                            gyroscope=rate[None], accelerometer=accelerometer[None],
                            rotor_speeds=np.full((1, 4), 1e4))
        controller.compute(np.zeros(1), state, hover_reference())
        forces.append(controller.force_estimate[0].copy())
        torques.append(controller.torque_estimate[0].copy())
        controller.applied(state, command[:1], command[None, 1:])
    np.testing.assert_allclose(np.array(forces), 0.0, atol=1e-9)
    torque_residual = [np.zeros(3)]
    for k in range(1, steps):
        mean = 0.5 * (rates[k] + rates[k - 1])
        torque_residual.append(J @ (rates[k] - rates[k - 1]) / DT + np.cross(mean, J @ mean)
                               - model[k][1:])
    numerator, denominator = analog_butterworth(bandwidth, DT)
    for axis in range(3):
        np.testing.assert_allclose(np.array(torques)[:, axis], filtered(
            np.array(torque_residual)[:, axis], numerator, denominator), rtol=1e-9, atol=1e-9)
    with pytest.raises(ValueError, match="actuator_state 'rpm'; valid: telemetry, model"):
        IncrementalNDI(actuator_state="rpm")
