"""Benchmark v3's loop factors (the real vehicle's lag and thrust path), each held to an
oracle written here from its equation, independent of the kernels' closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from gymnasium.utils import seeding

from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.params import VEHICLES
from quad_dob_env.scenarios import make_scenario

PAPER = VEHICLES["paper"]
K_F = PAPER.thrust_coefficient
DT = 0.01
HOVER_ROTOR = PAPER.hover_thrust / 4
STILL = {"initial_position_noise": 0.0, "initial_attitude_noise": 0.0}


def _core(scenario, n=1, action_mode="rotor_thrusts", seeds=None):
    core = QuadrotorBatch(scenario, n, action_mode=action_mode)
    seeds = list(range(1, n + 1)) if seeds is None else seeds
    core.reset(np.arange(n), [seeding.np_random(s)[0] for s in seeds])
    return core


def _mean_square(start, command, tau, elapsed, points=4001):
    """The mean of ω(t)² over ``elapsed`` for ω = c + (s - c) e^{-t/τ} (τ per rotor), by
    composite Simpson quadrature."""
    t = np.linspace(0.0, elapsed, points)
    omega = command[:, None] + (start - command)[:, None] * np.exp(-t / tau[:, None])
    y = omega**2
    h = t[1] - t[0]
    integral = h / 3 * (y[:, 0] + y[:, -1] + 4 * y[:, 1:-1:2].sum(1) + 2 * y[:, 2:-1:2].sum(1))
    return integral / elapsed


def _rotor_actions(core, thrusts):
    allocation = PAPER.allocation_matrix
    return core.action_map.to_actions(thrusts.sum()[None], (allocation[1:] @ thrusts)[None])


# --- the lag chain: motors spinning up and down at their own rates -------------------------

@pytest.mark.parametrize(("scale", "inner_rate"), [(1.0, None), (1.5, None), (1.0, 400.0)])
def test_each_rotor_speeds_up_and_slows_with_its_own_time_constant(scale, inner_rate):
    """Rotors commanded up follow e^{-t/τ_up}, those commanded down e^{-t/τ_down} (both
    times the scale); when the command reverses, each rotor switches; the reported thrust
    is k_F times the mean of ω² under the right exponential."""
    up, down = 0.03, 0.08
    scenario = make_scenario("hover-calm", speed_motors=True, motor_time_constants=(up, down),
                             motor_time_constant_scale=scale, inner_rate=inner_rate, **STILL)
    assert scenario.rotor_time_constants == (up * scale, down * scale)
    core = _core(scenario)
    omega0 = math.sqrt(HOVER_ROTOR / K_F)
    omega = np.full(4, omega0)
    for factors in ([1.2, 1.1, 0.9, 0.8], [0.85, 1.3, 1.0, 1.05]):
        thrusts = HOVER_ROTOR * np.array(factors)
        command = np.sqrt(thrusts / K_F)
        actions = _rotor_actions(core, thrusts)
        for _ in range(6):
            tau = np.where(command > omega, up, down) * scale
            expected = command + (omega - command) * np.exp(-DT / tau)
            mean = K_F * _mean_square(omega, command, tau, DT)
            core.step(actions)
            np.testing.assert_allclose(core.actuator_state[0], expected, rtol=1e-9)
            np.testing.assert_allclose(core.applied.rotor_thrusts[0], mean, rtol=1e-9)
            omega = expected


def test_equal_time_constants_fly_the_vehicles_one_bit_for_bit():
    """(τ, τ) given is the vehicle's own τ: the same flight to the last bit."""
    tau = PAPER.motor_time_constant
    flights = []
    for given in (None, (tau, tau)):
        scenario = make_scenario("hover-calm", speed_motors=True, motor_time_constants=given)
        core = _core(scenario, action_mode="thrust_moments")
        actions = np.array([[0.3, 0.1, -0.2, 0.05]])
        for _ in range(20):
            core.step(actions)
        flights.append((core.state.position.copy(), core.actuator_state.copy()))
    assert np.array_equal(flights[0][0], flights[1][0])
    assert np.array_equal(flights[0][1], flights[1][1])


@pytest.mark.parametrize(("given", "message"), [
    ((0.03,), "spin-up, spin-down"), ((0.03, -0.01), "motor_time_constants"),
    ((0.03, float("nan")), "motor_time_constants"), ("fast", "spin-up, spin-down")])
def test_bad_motor_time_constants_are_refused(given, message):
    with pytest.raises(ValueError, match=message):
        make_scenario("hover-calm", speed_motors=True, motor_time_constants=given)


def test_motor_time_constants_need_speed_motors():
    with pytest.raises(ValueError, match="speed_motors=True"):
        make_scenario("hover-calm", motor_time_constants=(0.03, 0.05))


# --- the thrust path: throttle map, battery, the autopilot's belief ------------------------

def _throttle_for(fraction, factor):
    """The u in [0, ∞) with (1 - κ) u + κ u² = fraction, from numpy's polynomial roots."""
    if factor == 0:
        return fraction
    roots = np.roots([factor, 1 - factor, -fraction])
    return float(max(r.real for r in roots if abs(r.imag) < 1e-12))


@pytest.mark.parametrize(("autopilot_factor", "tolerance"), [
    (0.0, None), (0.3, None), (0.0, {"mass": 0.05, "inertia": 0.1, "thrust_coefficient": 0.05})])
def test_the_throttle_map_turns_believed_thrust_into_the_rotors_truth(autopilot_factor,
                                                                       tolerance):
    """Per step: t_h = t_h0 + r t, t̂_h = t_h (1 + ε); u = the autopilot's model inverted at
    t̂_h T_c / T̂_h, held at 1; T = T_full ((1 - κ) u + κ u²) with T_full holding the
    *true* weight at the output the setpoint t_h asks for while the autopilot divides by
    the *told* one; the rotors lag to sqrt(T / k_F,true); the ceiling (here below the
    mixer's own limit) is reported as saturation."""
    factor = 0.6
    mapping = {"thrust_model_factor": factor, "hover_throttle": (0.44, 0.51),
               "hover_throttle_drift": (2e-4, 6e-4), "hover_estimate_error": 0.05,
               "autopilot_thrust_model_factor": autopilot_factor}
    scenario = make_scenario("hover-calm", speed_motors=True, thrust_uncertainty=False,
                             throttle_map=mapping, model_tolerance=tolerance, **STILL)
    core = _core(scenario, seeds=[7])
    drawn = core.sampled[0]
    hover0, drift = drawn["hover_throttle"], drawn["hover_throttle_drift"]
    estimate = drawn["hover_estimate_factor"]
    # told over true: the truth's mass and k_F are the told ones over these
    told_mass = drawn.get("mass_told_over_true", 1.0)
    told_k = drawn.get("thrust_coefficient_told_over_true", 1.0)
    assert tolerance is None or min(abs(told_mass - 1), abs(told_k - 1)) > 1e-3
    assert 0.44 <= hover0 <= 0.51 and 2e-4 <= drift <= 6e-4 and abs(estimate - 1) <= 0.05
    tau = PAPER.motor_time_constant
    omega = core.actuator_state[0].copy()
    believed_hover = PAPER.hover_thrust / 4
    # 2.3 x hover stays under the mixer's 25 N a rotor, over full throttle at these draws
    assert 2.3 * HOVER_ROTOR < PAPER.max_rotor_thrust
    for row, factors in enumerate([[1.2, 1.1, 0.9, 0.8]] * 5 + [[2.3, 1.0, 1.0, 1.0]] * 3):
        thrusts = HOVER_ROTOR * np.array(factors)
        t = row * DT
        true_hover = hover0 + drift * t
        np.testing.assert_allclose(core.loop.hover_throttle_estimate(core.time)[0],
                                   true_hover * estimate, rtol=1e-12)
        hover_output = _throttle_for(true_hover, autopilot_factor)
        full = (PAPER.mass / told_mass * PAPER.gravity / 4) / ((1 - factor) * hover_output
                                                               + factor * hover_output**2)
        throttle = np.array([_throttle_for(true_hover * estimate * c / believed_hover,
                                           autopilot_factor) for c in thrusts])
        ceiling = bool(np.any(throttle > 1))
        throttle = np.minimum(throttle, 1.0)
        true = full * ((1 - factor) * throttle + factor * throttle**2)
        command = np.sqrt(true / (K_F / told_k))
        omega = command + (omega - command) * math.exp(-DT / tau)
        core.step(_rotor_actions(core, thrusts))
        np.testing.assert_allclose(core.actuator_state[0], omega, rtol=1e-9)
        assert bool(core.applied.saturated[0]) == ceiling
    assert ceiling  # the last steps asked for more than full throttle on rotor 0


def test_a_calibrated_autopilot_gets_the_thrust_it_asks_for():
    """κ_ap = κ, no estimate error and no drift: below the ceiling each rotor settles on
    exactly the thrust the mixer asked for, whatever the pack's hover throttle."""
    mapping = {"thrust_model_factor": 0.5, "autopilot_thrust_model_factor": 0.5,
               "hover_throttle": (0.3, 0.6)}
    scenario = make_scenario("hover-calm", speed_motors=True, thrust_uncertainty=False,
                             throttle_map=mapping, **STILL)
    core = _core(scenario, seeds=[11])
    thrusts = HOVER_ROTOR * np.array([1.3, 0.7, 1.0, 1.1])
    actions = _rotor_actions(core, thrusts)
    for _ in range(120):  # 1.2 s, 30 time constants
        core.step(actions)
    np.testing.assert_allclose(K_F * core.actuator_state[0] ** 2, thrusts, rtol=1e-9)


def test_a_linear_autopilot_over_a_quadratic_rotor_gives_more_thrust_per_newton():
    """κ_ap = 0 over κ > 0: around hover, ∂T/∂T_c = ((1 - κ) + 2κ t_h) / ((1 - κ) + κ t_h),
    the gain a force following the commanded acceleration comes from."""
    factor, hover = 0.6, 0.47
    mapping = {"thrust_model_factor": factor, "hover_throttle": (hover, hover)}
    scenario = make_scenario("hover-calm", speed_motors=True, thrust_uncertainty=False,
                             throttle_map=mapping, **STILL)
    settled = []
    for extra in (-0.01, 0.0, 0.01):
        core = _core(scenario)
        actions = _rotor_actions(core, HOVER_ROTOR * np.full(4, 1 + extra))
        for _ in range(120):
            core.step(actions)
        settled.append(K_F * core.actuator_state[0, 0] ** 2)
    np.testing.assert_allclose(settled[1], HOVER_ROTOR, rtol=1e-9)
    # a central difference is exact on the quadratic
    gain = (settled[2] - settled[0]) / (0.02 * HOVER_ROTOR)
    expected = ((1 - factor) + 2 * factor * hover) / ((1 - factor) + factor * hover)
    np.testing.assert_allclose(gain, expected, rtol=1e-7)


def test_the_throttle_map_draws_from_its_own_stream():
    """Turning the map on changes no other draw: the start is the same to the bit."""
    starts = []
    for mapping in (None, {"thrust_model_factor": 0.5, "hover_throttle": (0.4, 0.5)}):
        scenario = make_scenario("hover-calm", speed_motors=True, thrust_uncertainty=False,
                                 throttle_map=mapping)
        core = _core(scenario, n=3, seeds=[4, 5, 6])
        starts.append((core.state.position.copy(), core.state.rotation.copy()))
    assert np.array_equal(starts[0][0], starts[1][0])
    assert np.array_equal(starts[0][1], starts[1][1])


@pytest.mark.parametrize(("mapping", "message"), [
    ({"thrust_model_factor": 1.5, "hover_throttle": (0.4, 0.5)}, "THR_MDL_FAC"),
    ({"thrust_model_factor": 0.5, "hover_throttle": (0.5, 0.4)}, "low <= high"),
    ({"thrust_model_factor": 0.5, "hover_throttle": 0.4}, r"\(low, high\) pair"),
    ({"thrust_model_factor": 0.5, "hover_throttle": (0.4, 0.5),
      "hover_estimate_error": 1.0}, "relative bound"),
    ({"thrust_model_factor": 0.5, "hover_throttle": (0.4, 0.5),
      "hover_throttle_drift": (-1e-3, 0.0)}, "0 <= low"),
    ({"thrust_model_factor": 0.5, "hover_throttle": (0.4, 0.5), "voltage": 16},
     "ThrottleMap field")])
def test_bad_throttle_maps_are_refused(mapping, message):
    with pytest.raises(ValueError, match=message):
        make_scenario("hover-calm", speed_motors=True, thrust_uncertainty=False,
                      throttle_map=mapping)


@pytest.mark.parametrize("loop", [{"speed_motors": False}, {"speed_motors": True,
                                                             "thrust_uncertainty": True}])
def test_the_throttle_map_needs_speed_motors_and_replaces_thrust_uncertainty(loop):
    with pytest.raises(ValueError, match="speed_motors=True, thrust_uncertainty=False"):
        make_scenario("hover-calm", throttle_map={"thrust_model_factor": 0.5,
                                                  "hover_throttle": (0.4, 0.5)}, **loop)


# --- the controllers' model of the vehicle -------------------------------------------------

def test_the_truth_is_the_told_model_over_a_factor_within_its_tolerance():
    """Told = truth × factor, factor uniform in 1 ± tolerance: the core flies mass m/f_m,
    inertia J/f_J, and rotors whose true thrust is k_F ω² / f_k while the telemetry says
    k_F ω²; the difference is in the reported disturbance."""
    tolerance = {"mass": 0.02, "inertia": 0.1, "thrust_coefficient": 0.05}
    scenario = make_scenario("hover-calm", speed_motors=True, model_tolerance=tolerance,
                             **STILL)
    core = _core(scenario, n=4, action_mode="thrust_moments", seeds=[1, 2, 3, 4])
    factors = np.array([[core.sampled[i][f"{name}_told_over_true"] for name in tolerance]
                        for i in range(4)])
    assert np.all(np.abs(factors - 1) <= list(tolerance.values()))
    assert np.ptp(factors, axis=0).min() > 0  # drawn per vehicle
    np.testing.assert_allclose(core.mass, PAPER.mass / factors[:, 0], rtol=1e-15)
    np.testing.assert_allclose(core.inertia, PAPER.inertia_matrix / factors[:, 1, None, None],
                               rtol=1e-15)
    core.step(np.zeros((4, 4)))
    omega_sq = core.actuator_state**2
    told = K_F * omega_sq.sum(axis=1)
    np.testing.assert_allclose(core.applied.thrust, told, rtol=0.02)  # the tick's mean
    extra = told / factors[:, 2] - told  # true k_F ω² / f_k beyond the told k_F ω²
    body_z = core.state.rotation[:, :, 2]
    np.testing.assert_allclose(core.disturbance_force, extra[:, None] * body_z, rtol=1e-9,
                               atol=1e-12)


def test_bad_model_tolerances_are_refused():
    with pytest.raises(ValueError, match="relative bound below 1"):
        make_scenario("hover-calm", speed_motors=True, model_tolerance={"mass": 1.0})
    with pytest.raises(ValueError, match="ModelTolerance field"):
        make_scenario("hover-calm", speed_motors=True, model_tolerance={"weight": 0.1})


# --- the values and their sources ----------------------------------------------------------

def test_every_v3_value_has_a_source_and_every_range_holds_its_nominal():
    import dataclasses

    from quad_dob_env.benchmark_v3 import ABLATION_ENDS, REAL_LOOPS, V3_SOURCES
    from quad_dob_env.sensing.models import SENSING_PRESETS

    for name, loop in REAL_LOOPS.items():
        assert name in VEHICLES
        # v3 flies the mocap preset's pose, whose latency is the one sourced here
        assert SENSING_PRESETS["mocap"].pose.latency == loop.pose_latency
        for field in dataclasses.fields(loop):
            value = getattr(loop, field.name)
            if dataclasses.is_dataclass(value):  # a record: each of its fields
                keys = [f"{field.name}.{inner.name}" for inner in dataclasses.fields(value)]
            else:
                keys = [field.name]
            for key in keys:
                assert key in V3_SOURCES, f"{name}: {key} has no source"
        for key, (low, high) in ABLATION_ENDS.items():
            path = key.replace(".up", "").replace(".down", "").split(".")
            value = loop
            for part in path:
                value = getattr(value, part)
            if isinstance(value, tuple):
                value = value[0 if key.endswith(".up") else 1]
            assert low <= value <= high, f"{key}: {value} outside its ends {low}-{high}"


# --- the autopilot's gyro low-pass ---------------------------------------------------------

def _butterworth_oracle(cutoff, rate):
    """(b, a) of the bilinear transform of H(s) = Ω² / (s² + √2 Ω s + Ω²), Ω prewarped:
    polynomials in z⁻¹ multiplied out with numpy, normalised to a0 = 1."""
    period = 1.0 / rate
    omega = 2.0 / period * math.tan(math.pi * cutoff * period)
    c = 2.0 / period  # s = c (1 - z⁻¹) / (1 + z⁻¹)
    minus, plus = np.array([1.0, -1.0]), np.array([1.0, 1.0])
    numerator = omega**2 * np.convolve(plus, plus)
    denominator = (c**2 * np.convolve(minus, minus) + math.sqrt(2) * omega * c
                   * np.convolve(minus, plus) + omega**2 * np.convolve(plus, plus))
    return numerator / denominator[0], denominator / denominator[0]


def _difference_equation(b, a, x, inputs, outputs):
    """y = b0 x + b1 x₋₁ + b2 x₋₂ - a1 y₋₁ - a2 y₋₂, appended to the histories."""
    y = b[0] * x + b[1] * inputs[-1] + b[2] * inputs[-2] - a[1] * outputs[-1] - a[2] * outputs[-2]
    inputs.append(x)
    outputs.append(y)
    return y


@pytest.mark.parametrize(("cutoff", "rate"), [(30.0, 200.0), (20.0, 400.0), (45.0, 100.0)])
def test_the_gyro_low_pass_is_the_prewarped_butterworth(cutoff, rate):
    from quad_dob_env.filters import butterworth_coefficients

    b, a = _butterworth_oracle(cutoff, rate)
    coefficients = butterworth_coefficients(cutoff, rate)
    np.testing.assert_allclose(coefficients, [*b, *a[1:]], rtol=1e-12, atol=1e-15)
    z = np.exp(-1j * 2 * math.pi * np.array([0.0, cutoff]) / rate)  # z⁻¹ at DC and the cutoff
    response = np.polyval(b[::-1], z) / np.polyval(a[::-1], z)
    np.testing.assert_allclose(np.abs(response), [1.0, math.sqrt(0.5)], rtol=1e-12)


@pytest.mark.parametrize(("initial_rate", "tolerance"), [
    ((0.0, 0.0, 0.0), None), ((0.3, -0.2, 0.05), None), ((0.0, 0.0, 0.0), {"inertia": 0.2})])
def test_the_rate_loop_reads_the_gyro_low_pass_stepped_once_a_tick(initial_rate, tolerance):
    """thrust_rates with one inner tick a step, no motor lag, ideal sensing: the filter's
    input is the true rate at each step's end (y = b·x - a·y, difference equation written
    here, settled on the initial rates), and each step's moment is the rate law on its last
    output, M = J k (ω_cmd - y) + y × J y, with the told (nominal) J under a model
    tolerance."""
    from quad_dob_env.envs.actions import MAX_RATE_COMMAND, RATE_GAIN

    cutoff, rate = 30.0, 100.0
    scenario = make_scenario("hover-calm", inner_rate=rate, gyro_cutoff=cutoff,
                             initial_angular_velocity=initial_rate, model_tolerance=tolerance,
                             **STILL)
    assert scenario.inner_ticks == 1
    core = _core(scenario, action_mode="thrust_rates")
    if tolerance is not None:  # the truth is off the told inertia
        assert abs(core.sampled[0]["inertia_told_over_true"] - 1) > 1e-3
    b, a = _butterworth_oracle(cutoff, rate)
    start = np.array(initial_rate)
    inputs, outputs = [start] * 2, [start] * 2  # settled on the initial rates
    J = PAPER.inertia_matrix
    generator = np.random.default_rng(0)
    for _ in range(25):
        # small yaw requests: the mixer gives yaw what headroom is left, and clips beyond it
        actions = np.concatenate([[0.0], generator.uniform(-0.3, 0.3, 2),
                                  generator.uniform(-0.01, 0.01, 1)])[None]
        held = outputs[-1]
        command = actions[0, 1:] * MAX_RATE_COMMAND
        expected = J @ (RATE_GAIN * (command - held)) + np.cross(held, J @ held)
        core.step(actions)
        np.testing.assert_allclose(core.applied.moment[0], expected, rtol=1e-9, atol=1e-12)
        x = core.state.angular_velocity[0].copy()
        y = _difference_equation(b, a, x, inputs, outputs)
        np.testing.assert_allclose(core.loop.gyro_output[0], y, rtol=1e-9, atol=1e-13)
    assert np.abs(outputs[-1] - inputs[-1]).max() > 1e-3  # the filter did lag the rates


@pytest.mark.parametrize(("options", "message"), [
    ({"gyro_cutoff": 30.0}, "no inner loop"),
    ({"gyro_cutoff": 100.0, "inner_rate": 200.0}, "Nyquist"),
    ({"gyro_cutoff": -1.0, "inner_rate": 200.0}, "gyro_cutoff")])
def test_bad_gyro_cutoffs_are_refused(options, message):
    with pytest.raises(ValueError, match=message):
        make_scenario("hover-calm", **options)


# --- vibration on the IMU --------------------------------------------------------------------

def test_vibration_adds_its_own_white_noise_to_every_imu_reading():
    """Each reading's white noise becomes sqrt(σ² + v²) for the sensor's σ = density / √dt:
    flown open loop with the same seed, the readings of two vibration levels differ from
    the still one's in the ratio (k₂ - 1) / (k₁ - 1), k = sqrt(σ² + v²) / σ (the same
    draws, scaled; no bias, so the white part is all of a reading's error)."""
    from quad_dob_env.sensing.models import MOCAP

    imu = {"gyroscope_noise_density": 1e-3, "accelerometer_noise_density": 2e-3,
           "gyroscope_bias_walk": 0.0, "accelerometer_bias_walk": 0.0}
    suite = {"name": "still-imu", "pose": MOCAP.pose, "imu": imu, "rotors": MOCAP.rotors,
             "estimator": MOCAP.estimator}
    levels = [(0.0, 0.0), (0.01, 0.3), (0.03, 0.7)]
    readings = []
    for vibration in levels:
        scenario = make_scenario("hover-calm", sensing=suite, imu_vibration=vibration)
        core = _core(scenario, seeds=[5])
        actions = _rotor_actions(core, HOVER_ROTOR * np.array([1.01, 1.0, 0.99, 1.0]))
        flight = []
        for _ in range(20):
            core.step(actions)
            flight.append(np.concatenate([core.measurement.gyroscope[0],
                                          core.measurement.accelerometer[0]]))
        readings.append(np.array(flight))
    sigma = np.array([1e-3] * 3 + [2e-3] * 3) / math.sqrt(DT)
    k = [np.sqrt(sigma**2 + np.repeat(v, 3) ** 2) / sigma for v in levels[1:]]
    first, second = readings[1] - readings[0], readings[2] - readings[0]
    np.testing.assert_allclose(second, first * (k[1] - 1) / (k[0] - 1), rtol=1e-6, atol=1e-12)
    assert np.abs(first).max() > 0.1  # the accelerometer's vibration is there


def test_vibration_needs_an_imu():
    with pytest.raises(ValueError, match="shakes an IMU"):
        make_scenario("hover-calm", imu_vibration=(0.0, 0.5))
    with pytest.raises(ValueError, match="imu_vibration"):
        make_scenario("hover-calm", sensing="mocap", imu_vibration=(0.0, -0.5))


# --- the pose's latency on the physics grid --------------------------------------------------

def _still_mocap(latency):
    from quad_dob_env.sensing.models import MOCAP

    return {"name": "still-mocap", "estimator": MOCAP.estimator, "rotors": MOCAP.rotors,
            "pose": {"kind": "mocap", "rate": 100.0, "latency": latency, "position_std": 0.0},
            "imu": {"gyroscope_noise_density": 0.0, "accelerometer_noise_density": 0.0,
                    "gyroscope_bias_walk": 0.0, "accelerometer_bias_walk": 0.0}}


@pytest.mark.parametrize(("latency", "extra"), [(0.010, 0.0), (0.005, 0.020), (0.015, 0.0)])
def test_at_50_hz_the_pose_fix_keeps_its_latency_on_the_tick_grid(latency, extra):
    """A 50 Hz loop with a 200 Hz inner loop (5 ms ticks): the fix read at step k is the
    true pose at t_k - (latency + extra), found by flying the same open-loop commands at
    200 Hz with the truth in view; on the control grid it would be 20 ms stale."""
    options = {"inner_rate": 200.0, "speed_motors": True, **STILL}
    fast = _core(make_scenario("hover-calm", dt=0.005, **options))
    slow = _core(make_scenario("hover-calm", dt=0.02, sensing=_still_mocap(latency),
                               extra_latency=extra, pose_latency_on_ticks=True, **options))
    late_ticks = round((latency + extra) / 0.005)
    assert slow.sensing.pose_delay.tolist() == [late_ticks // 4]
    thrusts = HOVER_ROTOR * np.array([1.3, 1.0, 0.8, 1.1])  # a climb, pitching and yawing
    truth = [(fast.state.position[0].copy(), fast.state.rotation[0].copy())]
    for _ in range(48):
        fast.step(_rotor_actions(fast, thrusts))
        truth.append((fast.state.position[0].copy(), fast.state.rotation[0].copy()))
    depth = slow.sensing.ring.shape[0]
    for k in range(1, 12):
        slow.step(_rotor_actions(slow, thrusts))
        q = slow.sensing.pose_delay[0]
        if 4 * k < late_ticks:  # before the start: the reset's reading
            continue
        # the fix read now: taken at step k - q, r ticks before that step's end
        row = slow.sensing.ring[(k - q) % depth, 0]
        position, rotation = truth[4 * k - late_ticks]
        np.testing.assert_allclose(row[0:3], position, rtol=0, atol=1e-12)
        np.testing.assert_allclose(row[3:12], rotation.ravel(), rtol=0, atol=1e-12)


@pytest.mark.parametrize(("dt", "on_ticks"), [(0.02, True), (0.01, False)])
def test_an_unmodelled_pose_latency_delays_the_fix_alone_and_is_not_told_the_estimator(
        dt, on_ticks):
    """The fix read at step k is the true pose at t_k - (latency + unmodelled) (on the tick
    grid or the control grid), while the IMU's delay and the lag the estimator is told
    stay those of the suite's own latency, and 0 changes nothing."""
    options = {"inner_rate": 200.0, "speed_motors": True, **STILL}
    latency, unmodelled = 0.010, 0.020
    fast = _core(make_scenario("hover-calm", dt=0.005, **options))
    flown = {name: _core(make_scenario(
        "hover-calm", dt=dt, sensing=_still_mocap(latency), pose_latency_on_ticks=on_ticks,
        unmodelled_pose_latency=extra, **options)) for name, extra in (
            ("told", 0.0), ("late", unmodelled))}
    told, late = flown["told"].sensing, flown["late"].sensing
    ticks = round(dt / 0.005)
    late_ticks = round((latency + unmodelled) / 0.005)
    if not on_ticks:  # on the control grid the fix is late by whole steps
        late_ticks = ticks * math.ceil(round((latency + unmodelled) / dt, 9))
    assert late.pose_delay.tolist() == [late_ticks // ticks]
    assert late.imu_delay == told.imu_delay
    assert late.lag == told.lag == told.pose_delay[0] - told.imu_delay
    thrusts = HOVER_ROTOR * np.array([1.3, 1.0, 0.8, 1.1])
    truth = [(fast.state.position[0].copy(), fast.state.rotation[0].copy())]
    for _ in range(12 * ticks):
        fast.step(_rotor_actions(fast, thrusts))
        truth.append((fast.state.position[0].copy(), fast.state.rotation[0].copy()))
    depth, q = late.ring.shape[0], late.pose_delay[0]
    for k in range(1, 12):
        for core in flown.values():
            core.step(_rotor_actions(core, thrusts))
        # the IMU rows the attitude loop and the filter read are the same in both
        np.testing.assert_array_equal(late.ring[k % depth, 0, 12:],
                                      told.ring[k % told.ring.shape[0], 0, 12:])
        if ticks * k < late_ticks:
            continue
        row = late.ring[(k - q) % depth, 0]
        position, rotation = truth[ticks * k - late_ticks]
        np.testing.assert_allclose(row[0:3], position, rtol=0, atol=1e-12)
        np.testing.assert_allclose(row[3:12], rotation.ravel(), rtol=0, atol=1e-12)


def test_an_unmodelled_pose_latency_needs_a_pose_fix():
    # refused when the scenario is made, before any env: the ideal sensing has no pose fix
    with pytest.raises(ValueError, match=r"unmodelled_pose_latency \(0\.02 s\) delays a "
                                         r"sensor suite's pose fix, but scenario 'hover-calm' "
                                         r"senses None"):
        make_scenario("hover-calm", unmodelled_pose_latency=0.02)
    with pytest.raises(ValueError, match=r"LoopOptions\.unmodelled_pose_latency"):
        make_scenario("hover-calm", unmodelled_pose_latency=-0.01)


def test_the_model_tolerance_composes_with_v2s_thrust_draws():
    """v2's thrust uncertainty asked for under v3 replaces the throttle map, not the model
    tolerance: the true k_F is thrust uncertainty's draw over the told factor."""
    scenario = make_scenario("hover-calm", benchmark="v3", thrust_uncertainty=True)
    assert scenario.loop.throttle_map is None and scenario.loop.model_tolerance is not None
    core = _core(scenario, seeds=[3])
    drawn = core.sampled[0]
    alone = _core(make_scenario("hover-calm", benchmark="v3", thrust_uncertainty=True,
                                model_tolerance=False), seeds=[3]).sampled[0]
    assert drawn["thrust_scale"] == pytest.approx(
        alone["thrust_scale"] / drawn["thrust_coefficient_told_over_true"], rel=1e-12)
    assert drawn["battery_sag_rate"] == alone["battery_sag_rate"]


def test_an_attitude_law_reads_the_gyro_low_pass_too():
    """The attitude-loop path (a controller's law at the inner rate) steps the same filter
    once a tick: with one tick a step and ideal sensing its output after each step is the
    difference equation over the true rates at the steps' ends."""
    import gymnasium as gym

    import quad_dob_env  # noqa: F401  (registers the ids)
    from quad_dob_composition import ReferencePolicy

    cutoff, rate = 30.0, 100.0
    env = gym.make("QuadDOB/Track-v1", scenario="dryden-helix-gusts",
                   scenario_options={"inner_rate": rate, "gyro_cutoff": cutoff})
    policy = ReferencePolicy("geometric-ndob:tuned", env)
    obs, _ = env.reset(seed=3)
    core = env.unwrapped.core
    assert core.attitude_loop is not None
    b, a = _butterworth_oracle(cutoff, rate)
    start = core.state.angular_velocity[0].copy()
    inputs, outputs = [start] * 2, [start] * 2
    for _ in range(30):
        obs, *_ = env.step(policy.predict(obs)[0])
        x = core.state.angular_velocity[0].copy()
        y = _difference_equation(b, a, x, inputs, outputs)
        np.testing.assert_allclose(core.loop.gyro_output[0], y, rtol=1e-9, atol=1e-12)
