"""Benchmark v2's vehicle loop (``quad_dob_env.dynamics.rotors``, ``envs.vehicle_loop``)
held to oracles written here from its equations: motors on rotor speed, rotor drag and
inflow against their formulas and blade-element momentum theory, the inner loop's rate,
thrust uncertainty's draws, v1 kept bit for bit with every switch off, and the refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from gymnasium.utils import seeding

from quad_dob_baselines import make_controller
from quad_dob_env.disturbances import Constant
from quad_dob_env.dynamics.rotors import RotorModel, rotor_wrench
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.params import VEHICLES
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.rollout import fly

PAPER = VEHICLES["paper"]
K_F = PAPER.thrust_coefficient
TAU = PAPER.motor_time_constant
DT = 0.01
HOVER_ROTOR = PAPER.hover_thrust / 4
# a still, level start: hover-calm's start noise would only blur what these tests measure
STILL = {"initial_position_noise": 0.0, "initial_attitude_noise": 0.0}
# flights seed 9001, as the rest of the suite's v1 checks
SEED = 9001
# v1's final position on dryden-helix-gusts, geometric-ndob:tuned, seed 9001 (test_sensing's
# V1_FLIGHTS, from the tree before the vehicle loop existed); 1e-9 m for another CPU's rounding
V1_HELIX_END = (3.9997213450948226, -0.023279804122310503, 2.649993491057723)


def _core(scenario, n=1, action_mode="thrust_moments", seeds=None):
    core = QuadrotorBatch(scenario, n, action_mode=action_mode)
    seeds = list(range(1, n + 1)) if seeds is None else seeds
    core.reset(np.arange(n), [seeding.np_random(s)[0] for s in seeds])
    return core


def _rotation(yaw=0.0, pitch=0.0, roll=0.0):
    """R = Rz(yaw) Ry(pitch) Rx(roll), body to world."""
    cz, sz, cy, sy, cx, sx = (math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch),
                              math.cos(roll), math.sin(roll))
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1.0]])
    ry = np.array([[cy, 0, sy], [0, 1.0, 0], [-sy, 0, cy]])
    rx = np.array([[1.0, 0, 0], [0, cx, -sx], [0, sx, cx]])
    return rz @ ry @ rx


def _hubs():
    """The paper vehicle's hubs (plus frame: rotor k on the arm at k·90°, at hub height)."""
    d, h = PAPER.arm_length, PAPER.rotor_height
    return np.array([[d * math.cos(k * math.pi / 2), d * math.sin(k * math.pi / 2), h]
                     for k in range(4)])


# Gill & D'Andrea 2019, Appendix A, APC 10x4.7 SF in oblique flow: C_T = C_s + k1 λ + k2 μ²
# + k3 λ² (their normalisation T = C_T ½ρπR²(ωR)²), written here from the paper's numbers
GILL_FIT = {"C_s": 0.032, "k1": -0.065, "k2": 0.17, "k3": -0.41}


def _gill_ratio(axial, inplane, tip):
    """T / T_static at fixed ω for airspeed ``axial`` through the disc (> 0: from above)
    and ``inplane`` across it, tip speed ``tip``; λ, μ held at 0.3 and λ's square only for
    λ > 0, as the env's law says."""
    lam = max(min(axial / tip, 0.3), -0.3)
    mu = min(inplane / tip, 0.3)
    fit = GILL_FIT
    return (fit["C_s"] + fit["k1"] * lam + fit["k2"] * mu**2
            + fit["k3"] * max(lam, 0.0) ** 2) / fit["C_s"]


def _oracle_wrench(speeds, v, R, omega, wind, scale=1.0):
    """Per rotor: u = Rᵀ(v - w) + Ω × p, D = -k_d ω (u_x, u_y, 0), T = max(κ k_F ω² + k_F ω²
    (Gill's ratio - 1), 0); force Σ (D_x, D_y, T), moment Σ p × (D_x, D_y, T) + spin c_τ κ
    k_F ω² e3 (the yaw torque ∝ ω², without the inflow's change)."""
    k_d = PAPER.rotor_drag_coefficient
    spin = PAPER.allocation_matrix[3]
    force, moment = np.zeros(3), np.zeros(3)
    air = R.T @ (np.asarray(v) - np.asarray(wind))
    for k, p in enumerate(_hubs()):
        u = air + np.cross(omega, p)
        w = speeds[k]
        static = K_F * w * w
        ratio = _gill_ratio(u[2], math.hypot(u[0], u[1]), w * PAPER.rotor_radius)
        f = np.array([-k_d * w * u[0], -k_d * w * u[1],
                      max(scale * static + static * (ratio - 1.0), 0.0)])
        force += f
        moment += np.cross(p, f) + np.array([0.0, 0.0, spin[k] * scale * static])
    return force, moment


def _call_wrench(speeds, v, R, omega, wind, scale=1.0):
    rotors = RotorModel.of(PAPER, False, False, True)
    force, moment = rotor_wrench(tuple(float(s) for s in speeds), tuple(map(float, v)),
                                 tuple(float(r) for r in np.asarray(R).reshape(9)),
                                 tuple(map(float, omega)), tuple(map(float, wind)),
                                 (float(scale),) * 4,
                                 rotors)
    return np.array(force), np.array(moment)


def _mean_square(start, command, tau, elapsed, points=4001):
    """The mean of ω(t)² over ``elapsed`` for ω = c + (s - c) e^{-t/τ}, by composite Simpson
    quadrature (independent of the closed form the env uses)."""
    t = np.linspace(0.0, elapsed, points)
    omega = command[:, None] + (start - command)[:, None] * np.exp(-t / tau)
    y = omega**2
    h = t[1] - t[0]
    integral = h / 3 * (y[:, 0] + y[:, -1] + 4 * y[:, 1:-1:2].sum(1) + 2 * y[:, 2:-1:2].sum(1))
    return integral / elapsed


# --- 1. motors on rotor speed ------------------------------------------------------------

@pytest.mark.parametrize(("scale", "inner_rate"), [(1.0, None), (1.5, None), (1.0, 400.0)])
def test_rotor_speeds_follow_the_first_order_step_response(scale, inner_rate):
    """A per-rotor thrust step: ω after k steps is ω_c + (ω0 - ω_c) e^{-k dt/τ} with
    τ = τ_vehicle · scale (an inner loop's ticks compose to the same exponential), the
    reported thrust is k_F Σ mean ω², and the physics lifts the vehicle with it."""
    scenario = make_scenario("hover-calm", speed_motors=True, motor_time_constant_scale=scale,
                             inner_rate=inner_rate, **STILL)
    assert not scenario.loop.motor_lag  # off: speed_motors alone turns the lag on
    core = _core(scenario, action_mode="rotor_thrusts")
    tau = TAU * scale
    omega0 = math.sqrt(HOVER_ROTOR / K_F)
    np.testing.assert_allclose(core.actuator_state[0], omega0, rtol=1e-12)
    thrusts = HOVER_ROTOR * np.array([1.2, 1.1, 0.9, 1.3])
    command = np.sqrt(thrusts / K_F)
    allocation = PAPER.allocation_matrix
    actions = core.action_map.to_actions(thrusts.sum()[None], (allocation[1:] @ thrusts)[None])
    assert np.all(np.abs(actions) < 1)
    omega = np.full(4, omega0)
    for k in range(1, 9):
        v_before = core.state.velocity[0].copy()
        core.step(actions)
        expected = command + (omega0 - command) * math.exp(-k * DT / tau)
        np.testing.assert_allclose(core.actuator_state[0], expected, rtol=1e-9)
        mean = K_F * _mean_square(omega, command, tau, DT)
        np.testing.assert_allclose(core.applied.rotor_thrusts[0], mean, rtol=1e-9)
        np.testing.assert_allclose(core.applied.thrust[0], mean.sum(), rtol=1e-9)
        assert not core.applied.saturated[0]
        if k == 1:  # still level: Δv_z = (k_F Σ mean ω² / m - g) dt, RK4's error ~1e-7
            lift = (mean.sum() / PAPER.mass - PAPER.gravity) * DT
            np.testing.assert_allclose(core.state.velocity[0, 2] - v_before[2], lift, rtol=1e-5)
        omega = expected


@pytest.mark.parametrize("speed_motors", [False, True])
def test_battery_sag_scales_the_command_and_thrust_scale_is_reported(speed_motors):
    """Each step's command thrust times (1 - r t)² at its start time t (on speed motors
    ω_c = sqrt of that over k_F, lagged), and the true thrust κ k_F ω² beyond the nominal
    k_F ω² is in the reported disturbance (no drag, no wind, no ground effect)."""
    scenario = make_scenario("hover-calm", speed_motors=speed_motors, thrust_uncertainty=True,
                             **STILL)
    core = _core(scenario, seeds=[3])
    kappa, rate = core.loop.thrust_scale[0], core.loop.sag_rate[0]
    assert core.sampled[0] == {"thrust_scale": kappa, "battery_sag_rate": rate}
    assert rate > 1e-5  # this seed's sag is large enough to see at 1e-9
    thrust = 1.1 * PAPER.hover_thrust
    actions = core.action_map.to_actions(np.array([thrust]), np.zeros((1, 3)))
    omega = np.full(4, math.sqrt(HOVER_ROTOR / K_F))
    decay = math.exp(-DT / TAU)
    for row in range(30):
        core.step(actions)
        sagged = (1 - rate * row * DT) ** 2 * thrust / 4
        if speed_motors:
            command = math.sqrt(sagged / K_F)
            omega = command + (omega - command) * decay
            np.testing.assert_allclose(core.actuator_state[0], omega, rtol=1e-9)
        else:  # no motor lag: the rotors give the sagged command at once
            omega = np.full(4, math.sqrt(sagged / K_F))
            np.testing.assert_allclose(core.actuator_state[0], sagged, rtol=1e-12)
            np.testing.assert_allclose(core.applied.thrust[0], 4 * sagged, rtol=1e-12)
    extra = (kappa - 1) * K_F * (omega**2).sum()
    np.testing.assert_allclose(core.disturbance_force[0],
                               core.state.rotation[0] @ [0.0, 0.0, extra], rtol=1e-9,
                               atol=1e-12)
    # the yaw torque goes with the true thrust too; equal rotors cancel it
    np.testing.assert_allclose(core.disturbance_torque[0], 0.0, atol=1e-12)


# --- 2. rotor drag -----------------------------------------------------------------------

def test_rotor_model_hubs_are_the_plus_frames():
    model = RotorModel.of(PAPER, True, True, True)
    np.testing.assert_allclose(model.positions, _hubs(), atol=1e-15)
    np.testing.assert_array_equal(model.spin, PAPER.allocation_matrix[3])


@pytest.mark.parametrize("airspeed", [2.0, 6.0, 12.0])
@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, 90.0, 200.0])
def test_rotor_wrench_matches_the_per_rotor_formulas(airspeed, yaw_deg):
    """Unequal speeds, wind from one side and the vehicle moving: the compiled wrench is the
    per-rotor sum; then equal speeds and no rates: in-plane drag -4 k_d ω (u_x, u_y) in the
    body frame, the same world vector at any heading, and a moment p_z e3 × D only."""
    yaw = math.radians(yaw_deg)
    R = _rotation(yaw)
    wind = airspeed * np.array([0.8, -0.6, 0.0])
    v = np.array([0.3, 0.2, -0.1])
    speeds = math.sqrt(HOVER_ROTOR / K_F) * np.array([1.05, 0.97, 1.02, 0.93])
    omega = np.zeros(3)
    for args in ((speeds, v, R, omega, wind, 1.03),
                 (speeds, v, _rotation(yaw, 0.2, -0.15), np.array([0.4, -0.7, 1.1]), wind,
                  0.97)):
        force, moment = _call_wrench(*args)
        expected_force, expected_moment = _oracle_wrench(*args)
        np.testing.assert_allclose(force, expected_force, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(moment, expected_moment, rtol=1e-12, atol=1e-12)
    # equal speeds, zero rates, level: the drag is the vehicle's whatever its heading
    w = math.sqrt(HOVER_ROTOR / K_F)
    force, moment = _call_wrench(np.full(4, w), np.zeros(3), R, omega, wind)
    u = R.T @ (-wind)
    drag = -4 * PAPER.rotor_drag_coefficient * w * u[:2]
    np.testing.assert_allclose(force[:2], drag, rtol=1e-12)
    world = R @ np.array([*force[:2], 0.0])
    np.testing.assert_allclose(world[:2], 4 * PAPER.rotor_drag_coefficient * w * wind[:2],
                               rtol=1e-12)
    # no axial inflow: the thrust's only change is the edgewise gain of the in-plane flow
    edgewise = _gill_ratio(0.0, float(np.linalg.norm(u[:2])), w * PAPER.rotor_radius)
    np.testing.assert_allclose(force[2], 4 * K_F * w * w * edgewise, rtol=1e-12)
    pitching = np.cross([0.0, 0.0, PAPER.rotor_height], [*drag, 0.0])
    np.testing.assert_allclose(moment, pitching, rtol=1e-12, atol=1e-12)
    assert abs(moment[0]) + abs(moment[1]) > 0.1 * PAPER.rotor_height * np.linalg.norm(drag)


# --- 3. thrust in oblique flow -----------------------------------------------------------

def test_thrust_in_oblique_flow_follows_gill_and_dandreas_fit():
    """At fixed ω the thrust falls with airflow through the disc from above (climb), rises
    with it from below, gains with airflow across it (translational lift), all as the
    published fit's ratios; the vehicles' k_z is the fit's linear term."""
    w = math.sqrt(HOVER_ROTOR / K_F)
    tip = w * PAPER.rotor_radius
    fit = GILL_FIT
    assert PAPER.inflow_coefficient == pytest.approx(-K_F * fit["k1"] / fit["C_s"]
                                                     / PAPER.rotor_radius, rel=1e-12)
    assert PAPER.inflow_quadratic == pytest.approx((fit["k2"] / fit["C_s"],
                                                    fit["k3"] / fit["C_s"]), rel=1e-12)
    hover = 4 * HOVER_ROTOR
    assert _call_wrench(np.full(4, w), np.zeros(3), np.eye(3), np.zeros(3),
                        np.zeros(3))[0][2] == pytest.approx(hover, rel=1e-12)
    for climb, side in [(-3.0, 0.0), (-1.0, 0.0), (1.0, 0.0), (3.0, 0.0), (0.0, 5.0),
                        (0.0, 12.0), (2.0, 8.0), (6.0, 10.0), (0.0, 60.0), (40.0, 0.0),
                        (-40.0, 0.0)]:
        thrust = _call_wrench(np.full(4, w), [side, 0.0, climb], np.eye(3), np.zeros(3),
                              np.zeros(3))[0][2]
        assert thrust == pytest.approx(max(hover * _gill_ratio(climb, side, tip), 0.0),
                                       rel=1e-9, abs=1e-12), (climb, side)
    # a rotor spinning slowly in a fast descent gains at most 0.3 |k1|/C_s of its thrust
    slow = 50.0
    descending = _call_wrench(np.full(4, slow), [0.0, 0.0, -5.0], np.eye(3), np.zeros(3),
                              np.zeros(3))[0][2]
    assert descending == pytest.approx(4 * K_F * slow**2 * (1 - 0.3 * fit["k1"] / fit["C_s"]),
                                       rel=1e-9)
    assert _call_wrench(np.zeros(4), [3.0, 0.0, -5.0], np.eye(3), np.zeros(3),
                        np.zeros(3))[0][2] == 0.0  # no thrust from a stopped rotor
    assert _call_wrench(np.full(4, w), [0.0, 0.0, 1.0], np.eye(3), np.zeros(3),
                        np.zeros(3))[0][2] < hover  # climbing
    assert _call_wrench(np.full(4, w), [8.0, 0.0, 0.0], np.eye(3), np.zeros(3),
                        np.zeros(3))[0][2] > hover  # edgewise


def test_neural_fly_in_the_tunnels_strongest_wind_keeps_nine_tenths_of_its_thrust():
    """Neural-Fly's vehicle holding station at 12.1 m/s leans atan(15.7 / mg) ≈ 32° into
    the wind; at its hover ω the fit keeps 0.89 of the static thrust (part 2's linear law,
    Padfield's hover slope, 3.6x steeper, kept 0.60 and lost the flight; Neural-Fly's logs
    show under ~10 % lost)."""
    nf = VEHICLES["neural-fly"]
    lean = math.atan2(15.7, nf.mass * 9.81)
    w = math.sqrt(nf.hover_thrust / 4 / nf.thrust_coefficient)
    tip = w * nf.rotor_radius
    axial, inplane = 12.1 * math.sin(lean), 12.1 * math.cos(lean)
    ratio = _gill_ratio(axial, inplane, tip)
    assert ratio == pytest.approx(0.891, abs=0.005)  # an outside evaluation's 0.891
    rotors = RotorModel.of(nf, False, False, True)
    rotation = np.array([[math.cos(lean), 0.0, math.sin(lean)], [0.0, 1.0, 0.0],
                         [-math.sin(lean), 0.0, math.cos(lean)]])  # tilted toward +x
    force, _ = rotor_wrench((w,) * 4, (0.0, 0.0, 0.0), tuple(rotation.reshape(9)),
                            (0.0, 0.0, 0.0), (-12.1, 0.0, 0.0), (1.0,) * 4, rotors)
    assert force[2] == pytest.approx(nf.hover_thrust * ratio, rel=1e-9)


# --- 4. the total drag at 12 m/s ---------------------------------------------------------

def _windy_hover(**options):
    return make_scenario("hover-calm", drag=True, disturbance=Constant(wind=(12.0, 0.0, 0.0)),
                         **STILL, **options)


def test_rotor_drag_and_body_drag_make_v1s_drag_at_12_m_s():
    """Level at hover speeds in 12 m/s of wind: the reported disturbance is the body drag
    -c2 |u| u (c1 zeroed) plus the rotor wrench beyond the nominal, within 15 % of v1's
    drag 0.3·12 + 0.06·12², which v1's own flight reports."""
    v1_drag = 0.3 * 12 + 0.06 * 12**2
    core = _core(_windy_hover(rotor_aerodynamics=True))
    core.step(np.zeros((1, 4)))
    R, v = core.state.rotation[0], core.state.velocity[0]
    omega = core.state.angular_velocity[0]
    wind = np.array([12.0, 0.0, 0.0])
    np.testing.assert_allclose(core.wind_velocity[0], wind)
    speeds = np.sqrt(core.actuator_state[0] / K_F)  # rotor thrusts: no speed motors
    force, moment = _oracle_wrench(speeds, v, R, omega, wind)
    u = R.T @ (v - wind)
    body = -np.array(PAPER.drag_quadratic) * np.linalg.norm(u) * u
    body[2] += force[2] - K_F * (speeds**2).sum()
    body[:2] += force[:2]
    expected = R @ body
    np.testing.assert_allclose(core.disturbance_force[0], expected, rtol=1e-9, atol=1e-12)
    # the torque: the true rotor moment (drag at hub height pitches it) beyond the nominal
    nominal = PAPER.allocation_matrix[1:] @ (K_F * speeds**2)
    np.testing.assert_allclose(core.disturbance_torque[0], moment - nominal, rtol=1e-9,
                               atol=1e-12)
    # h · 4 k_d ω 12 = 0.2 N m about +y: the hubs, pushed downwind, tip the vehicle downwind
    assert core.disturbance_torque[0, 1] > 0.1
    drag = core.disturbance_force[0, 0]
    assert drag == pytest.approx(v1_drag, rel=0.15)
    v1 = _core(_windy_hover())
    v1.step(np.zeros((1, 4)))
    assert v1.disturbance_force[0, 0] == pytest.approx(v1_drag, rel=0.01)
    assert drag == pytest.approx(v1.disturbance_force[0, 0], rel=0.15)


# --- 5. the inner loop's rate law --------------------------------------------------------

@pytest.mark.parametrize(("inner_rate", "per_step"), [(None, 1 - 20 * 0.01),
                                                      (400.0, (1 - 20 * 0.0025) ** 4)])
def test_inner_loop_holds_a_rate_command_at_its_rate(inner_rate, per_step):
    """thrust_rates from rest, roll rate 0.5 rad/s: M = J·20·(ω_cmd - ω) held over each tick
    (no motor lag), so ω moves linearly in a tick and the error shrinks by (1 - 20 h) per
    tick; pure roll keeps ω × Jω = 0."""
    scenario = make_scenario("hover-calm", inner_rate=inner_rate, **STILL)
    assert not scenario.loop.motor_lag and scenario.loop.sensing is None
    core = _core(scenario, action_mode="thrust_rates")
    actions = np.array([[0.0, 0.5 / 4.0, 0.0, 0.0]])
    error = 0.5
    for _ in range(5):
        core.step(actions)
        error *= per_step
        rates = core.state.angular_velocity[0]
        np.testing.assert_allclose(0.5 - rates[0], error, rtol=1e-6)
        np.testing.assert_allclose(rates[1:], 0.0, atol=1e-12)
        assert not core.applied.saturated[0]


@pytest.mark.parametrize("factors", [{}, {"speed_motors": True},
                                     {"speed_motors": True, "thrust_uncertainty": True,
                                      "rotor_aerodynamics": True}])
def test_ticks_of_a_held_command_are_substeps(factors):
    """A command held over the step (thrust_moments) flown as 4 inner ticks is the same
    physics as 4 substeps of one interval: the lag's exponentials compose and each tick
    reads its quarter of the disturbance samples (Dryden wind, gusts, drag, motor lag)."""
    def flown(**options):
        core = _core(make_scenario("dryden-helix-gusts", **factors, **options), 2)
        record = []
        for k in range(60):
            core.step(0.05 * np.sin(0.1 * k + np.arange(4))[None].repeat(2, 0))
            record.append(np.concatenate([
                core.state.position, core.state.velocity, core.state.rotation.reshape(2, 9),
                core.state.angular_velocity, core.applied.rotor_thrusts,
                core.disturbance_force, core.disturbance_torque, core.wind_velocity], 1))
        return np.array(record), core.actuator_state.copy()

    ticks, ticks_end = flown(inner_rate=400.0)
    substeps, substeps_end = flown(substeps=4)
    np.testing.assert_allclose(ticks, substeps, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(ticks_end, substeps_end, rtol=1e-12)


@pytest.mark.parametrize("sensing", ["ideal", "mocap", "gnss-imu"])
def test_one_tick_rate_loop_is_the_control_rate_one(sensing):
    """inner_rate = 1/dt runs thrust_rates' rate law once a step: the flight without an
    inner loop, whatever the sensing (both should read the same rates)."""
    def rates(**options):
        core = _core(make_scenario("hover-calm", sensing=sensing, **options),
                     action_mode="thrust_rates", seeds=[3])
        for _ in range(20):
            core.step(np.array([[0.0, 0.1, -0.05, 0.02]]))
        return core.state.angular_velocity[0].copy()

    np.testing.assert_allclose(rates(inner_rate=100.0), rates(), rtol=0, atol=1e-12)


# --- 6. the controllers' attitude laws at the inner rate ---------------------------------

@pytest.mark.parametrize("name", ["geometric", "geometric-ndob:tuned", "pid", "smc"])
def test_inner_loop_at_the_control_rate_flies_v1(name):
    """One tick a step runs the compiled attitude law once a step, as the controller does:
    the same flight to 1e-12; at 400 Hz a different flight, finite, of like accuracy."""
    flights = {rate: fly(make_controller(name), make_scenario("dryden-helix-gusts",
                                                              inner_rate=rate), seed=SEED)[0]
               for rate in (None, 100.0, 400.0)}
    base, one, fast = flights[None], flights[100.0], flights[400.0]
    for field in ("position", "velocity", "rotation", "applied_thrust"):
        np.testing.assert_allclose(getattr(one, field), getattr(base, field), rtol=0,
                                   atol=1e-12, err_msg=field)
    assert len(fast.position) == len(base.position) == 1000
    assert np.all(np.isfinite(fast.position)) and np.all(np.isfinite(fast.rotation))
    assert not np.array_equal(fast.position, base.position)

    def rms(flight):
        return np.sqrt(np.mean(np.sum((flight.position - flight.reference_position) ** 2, 1)))

    assert 1 / 1.5 < rms(fast) / rms(base) < 1.5


# --- 7. each switch off is v1 ------------------------------------------------------------

FACTORS = {"speed_motors": True, "thrust_uncertainty": True, "rotor_aerodynamics": True,
           "inner_rate": 400.0}


def test_every_switch_off_is_v1_and_each_on_changes_the_flight():
    controller = "geometric-ndob:tuned"
    default = fly(make_controller(controller), make_scenario("dryden-helix-gusts"), SEED)[0]
    off = fly(make_controller(controller), make_scenario(
        "dryden-helix-gusts", speed_motors=False, thrust_uncertainty=False,
        rotor_aerodynamics=False, inner_rate=None), SEED)[0]
    for field in ("position", "velocity", "rotation", "applied_thrust", "disturbance_force"):
        assert np.array_equal(getattr(off, field), getattr(default, field)), field
    np.testing.assert_allclose(default.position[-1], V1_HELIX_END, rtol=0, atol=1e-9)
    for factor, value in FACTORS.items():
        flown = fly(make_controller(controller),
                    make_scenario("dryden-helix-gusts", **{factor: value}), SEED)[0]
        assert len(flown.position) == 1000, factor
        assert not np.array_equal(flown.position, default.position), factor


def test_thrust_uncertainty_draws_from_its_own_stream():
    """κ ~ U(0.95, 1.05), r ~ U(0, 2.5e-4) from the vehicle generator's second child, so the
    start and the wind draw the same numbers with the factor on or off."""
    seeds = list(range(100, 116))
    scenario = make_scenario("dryden-helix-gusts", initial_position_noise=0.1)
    cores = [_core(scenario.with_changes(thrust_uncertainty=on), len(seeds), seeds=seeds)
             for on in (False, True)]
    np.testing.assert_array_equal(cores[0].state.position, cores[1].state.position)
    assert np.ptp(cores[0].state.position[:, 0]) > 0.01  # the start was drawn
    for _ in range(50):
        for core in cores:
            core.step(np.zeros((len(seeds), 4)))
        np.testing.assert_array_equal(cores[0].wind_velocity, cores[1].wind_velocity)
    assert np.ptp(cores[0].wind_velocity[:, 0]) > 0.1  # the wind was drawn per vehicle
    loop = cores[1].loop
    for i, seed in enumerate(seeds):
        # the reset's one child is the sensors'; the rotors draw from a grandchild
        child = seeding.np_random(seed)[0].spawn(1)[0].spawn(1)[0]
        assert loop.thrust_scale[i] == child.uniform(0.95, 1.05)
        assert loop.sag_rate[i] == child.uniform(0.0, 2.5e-4)
        assert cores[1].sampled[i]["thrust_scale"] == loop.thrust_scale[i]
        assert cores[1].sampled[i]["battery_sag_rate"] == loop.sag_rate[i]
        assert "thrust_scale" not in cores[0].sampled[i]
    assert np.all((loop.thrust_scale >= 0.95) & (loop.thrust_scale <= 1.05))
    assert np.all((loop.sag_rate >= 0.0) & (loop.sag_rate <= 2.5e-4))
    assert len(np.unique(loop.thrust_scale)) == len(np.unique(loop.sag_rate)) == len(seeds)
    np.testing.assert_array_equal(cores[0].loop.thrust_scale, 1.0)


# --- 8. refusals -------------------------------------------------------------------------

@pytest.mark.parametrize("rate", [150.0, -1.0, 20000.0, float("nan")])
def test_bad_inner_rate_is_refused(rate):
    with pytest.raises(ValueError, match="inner_rate"):
        make_scenario("hover-calm", inner_rate=rate)


@pytest.mark.parametrize("factor", ["speed_motors", "thrust_uncertainty", "rotor_aerodynamics"])
def test_rotor_factors_refuse_the_wrench(factor):
    options = {factor: True, "drag": True}
    with pytest.raises(ValueError, match=factor):
        make_scenario("paper-II", **options)


def test_rotor_aerodynamics_needs_drag():
    with pytest.raises(ValueError, match="rotor_aerodynamics"):
        make_scenario("hover-calm", rotor_aerodynamics=True)


# --- 12. what the review of the change asked for ------------------------------------------

# Final states on the tree before the vehicle loop (commit c1e47fc, part 1): sensing over
# autoresets, thrust_rates, the ground effect and a landing; this tree gave them bit for bit
# on the project's VM (1e-9 m for another CPU's rounding). Printed by flying the cases below.
PART1_RECORDS = {
    "gnss-autoreset": [[0.008119803524856183, 0.024980924594372143, 2.599840052056767],
                       [0.00809575589902959, 0.025262260857149207, 2.5999701735807483]],
    "rates-ideal": [-0.2226809317128856, -0.14058187506799724, 1.130885921805347,
                    0.39999430783579465, -0.19999711142147134, 0.07999886055576484],
    "smc-takeoff": [[-0.011119221462596345, 0.01052494963590726, 1.002285633172367],
                    [-0.0046619687042040265, 0.010765821348301103, 1.0019557593564097]],
    "pid-ground-effect": [[0.0, 0.0, 0.1412462065817625]],
}


def _residual_env(n, scenario, base, **options):
    from quad_dob_composition import ResidualVectorEnv
    return ResidualVectorEnv(n, scenario, scenario_options=options or None,
                             base_controller=base)


def _rates_flight(sensing):
    core = _core(make_scenario("hover-calm", sensing=sensing), action_mode="thrust_rates",
                 seeds=[3])
    for _ in range(50):
        core.step(np.array([[0.05, 0.1, -0.05, 0.02]]))
    return core.state.position[0].tolist() + core.state.angular_velocity[0].tolist()


def test_part_one_flights_are_kept_bit_for_bit():
    """Sensor keys over three episodes (one child spawned per reset, as before), thrust_rates,
    ground effect and landing: as on the tree before the vehicle loop."""
    env = _residual_env(2, "dryden-helix-gusts", "geometric-ndob:tuned", sensing="gnss-imu",
                        duration=0.3)
    env.reset(seed=5)
    for _ in range(95):  # three episodes of 30 steps, autoreset between them
        env.step(np.zeros((2, 4)))
    np.testing.assert_allclose(env.core.state.position, PART1_RECORDS["gnss-autoreset"],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(_rates_flight("ideal"), PART1_RECORDS["rates-ideal"], rtol=0,
                               atol=1e-9)
    for name, scenario, base, steps, seed in (("smc-takeoff", "takeoff-landing-wind", "smc",
                                               400, 7),
                                              ("pid-ground-effect", "ground-effect-landing",
                                               "pid", 300, 1)):
        expected = np.array(PART1_RECORDS[name])
        env = _residual_env(len(expected), scenario, base)
        env.reset(seed=seed)
        for _ in range(steps):
            env.step(np.zeros((len(expected), 4)))
        np.testing.assert_allclose(env.core.state.position, expected, rtol=0, atol=1e-9)


def test_thrust_rates_reads_the_gyro_it_is_given_not_the_truth():
    """Before the vehicle loop, thrust_rates' rate loop read the true rates under any
    sensing (the mocap flight was the ideal one to the last bit); now the estimate."""
    mocap = _rates_flight("mocap")
    assert np.abs(np.subtract(mocap, PART1_RECORDS["rates-ideal"])).max() > 1e-5


def test_the_residual_rides_on_the_inner_loop():
    """A constant residual is added to the base's law at every tick: at one tick a step the
    flight is the one without an inner loop (1e-12); at 400 Hz it differs and is finite."""
    residual = np.tile([0.05, 0.02, -0.03, 0.01], (2, 1))

    def flown(**options):
        env = _residual_env(2, "dryden-helix-gusts", "geometric-ndob:tuned", **options)
        env.reset(seed=11)
        for _ in range(150):
            env.step(residual)
        return env.core.state.position.copy(), env.core.applied.thrust.copy()

    plain, one, fast = flown(), flown(inner_rate=100.0), flown(inner_rate=400.0)
    np.testing.assert_allclose(one[0], plain[0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(one[1], plain[1], rtol=1e-12)
    assert np.all(np.isfinite(fast[0])) and not np.array_equal(fast[0], plain[0])


def test_reference_policy_flies_its_attitude_law_at_the_inner_rate():
    """ReferencePolicy installs the controller's attitude loop on the env it drives: at one
    tick a step, the flight without an inner loop (to the float32 rounding of the actions
    that flight goes through, ~1e-7 of the command)."""
    import gymnasium as gym

    import quad_dob_env  # noqa: F401  (registers the ids)
    from quad_dob_composition import ReferencePolicy

    def flown(**options):
        env = gym.make("QuadDOB/Track-v1", scenario="dryden-helix-gusts",
                       scenario_options=options or None)
        policy = ReferencePolicy("pid", env)
        obs, _ = env.reset(seed=SEED)
        for _ in range(120):
            obs, *_ = env.step(policy.predict(obs)[0])
        return env.unwrapped.core.state.position[0].copy()

    held = flown()
    np.testing.assert_allclose(flown(inner_rate=100.0), held, rtol=0, atol=1e-6)
    assert np.abs(flown(inner_rate=400.0) - held).max() > 1e-6


def test_the_inner_rotational_observer_settles_on_a_constant_torque():
    """The rotational observer runs at the tick with gains discretised for it: a constant
    torque's estimate converges (the tuned preset's 5 /s: 0.2 s time constant)."""
    torque = np.array([0.3, -0.2, 0.1])
    scenario = make_scenario("hover-calm", disturbance=Constant(torque=torque),
                             inner_rate=400.0, **STILL)
    flight = fly(make_controller("geometric-ndob:tuned"), scenario, seed=SEED)[0]
    np.testing.assert_allclose(flight.torque_estimate[-1], torque, rtol=0, atol=2e-3)
    np.testing.assert_allclose(flight.disturbance_torque[-1], torque, rtol=0, atol=1e-12)


def test_an_empty_battery_makes_no_thrust_rather_than_more():
    """(1 - r t)² would rise again past t = 1/r; the sag stops at an empty pack."""
    scenario = make_scenario("hover-calm", thrust_uncertainty=True, motor_lag=False, **STILL)
    core = _core(scenario)
    core.loop.sag_rate[:] = 1.0  # empty after 1 s
    for _ in range(110):
        core.step(np.zeros((1, 4)))
    assert core.applied.thrust[0] == 0.0


def _hat(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _lee_moment(R, W, Rd, Wd, Ad, J, kR, kW):
    """Lee 2010: eR = ½ vee(RdᵀR - RᵀRd), eΩ = Ω - RᵀRd Ωd,
    M = -kR eR - kΩ eΩ + Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d)."""
    skew = Rd.T @ R - R.T @ Rd
    e_r = 0.5 * np.array([skew[2, 1], skew[0, 2], skew[1, 0]])
    e_w = W - R.T @ Rd @ Wd
    return (-kR * e_r - kW * e_w + np.cross(W, J @ W)
            - J @ (_hat(W) @ R.T @ Rd @ Wd - R.T @ Rd @ Ad))


def _rigid_body(R, W, M, J, duration, steps=400):
    """J Ω̇ = M - Ω × JΩ, Ṙ = R hat(Ω) under a constant moment, by fine RK4."""
    inverse, h = np.linalg.inv(J), duration / steps

    def derivative(R, W):
        return R @ _hat(W), inverse @ (M - np.cross(W, J @ W))

    for _ in range(steps):
        k1 = derivative(R, W)
        k2 = derivative(R + h / 2 * k1[0], W + h / 2 * k1[1])
        k3 = derivative(R + h / 2 * k2[0], W + h / 2 * k2[1])
        k4 = derivative(R + h * k3[0], W + h * k3[1])
        R = R + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        W = W + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        u, _, vt = np.linalg.svd(R)
        R = u @ vt
    return R, W


def test_the_inner_loop_holds_an_attitude_command_at_its_rate():
    """From a tilted start, one control step at 400 Hz: the attitude command (Rd, Ωd, Ω̇d) of
    the step's outer part held, Lee's moment recomputed from the attitude at each of the four
    ticks and held within it, the rigid body integrated by a fine RK4 in between; against a
    moment held over the whole step, as the monolithic controller does."""
    from quad_dob_composition.attitude_loop import AttitudeLoop

    tilt = _rotation(roll=0.2, pitch=-0.1, yaw=0.05)
    scenario = make_scenario("hover-calm", actuation="wrench", motor_lag=False,
                             initial_rotation=tuple(map(tuple, tilt)), inner_rate=400.0,
                             initial_angular_velocity=(0.3, -0.2, 0.1), **STILL)
    core = _core(scenario)
    controller = make_controller("geometric")
    AttitudeLoop.install(core, controller)
    controller.reset(1, core.vehicle, DT, actuation="wrench")
    thrust, moment = controller.compute(core.time, core.measurement, core.reference)
    d = controller.diagnostics
    held = (d["desired_rotation"][0].copy(), d["desired_angular_velocity"][0].copy(),
            d["desired_angular_acceleration"][0].copy())
    J = PAPER.inertia_matrix
    gains = (controller.gains["kR"], controller.gains["kOmega"])
    R, W = core.state.rotation[0].copy(), core.state.angular_velocity[0].copy()
    start = (R, W)
    core.step(core.action_map.to_actions(thrust, moment))
    for _ in range(4):
        R, W = _rigid_body(R, W, _lee_moment(R, W, *held, J, *gains), J, DT / 4, steps=100)
    np.testing.assert_allclose(core.state.rotation[0], R, rtol=0, atol=1e-9)
    np.testing.assert_allclose(core.state.angular_velocity[0], W, rtol=0, atol=1e-9)
    _, held_W = _rigid_body(*start, _lee_moment(*start, *held, J, *gains), J, DT)
    assert np.abs(held_W - W).max() > 1e-3  # the ticks made a different step
