"""The package held to an independent oracle (``tests/oracle.py``) written from docs/design.md's
equations: one physics step on random states, the mixer, Lee's law, and whole closed-loop
flights of each scenario family with the observer."""

from __future__ import annotations

import math

import numpy as np
import oracle
import pytest
from gymnasium.utils import seeding

from quad_dob_baselines import (
    TUNED_OBSERVER_RATES,
    GeometricController,
    NonlinearDisturbanceObserver,
    make_controller,
)
from quad_dob_env.disturbances import Constant, Gust
from quad_dob_env.dynamics import Actuator, VehicleState
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.so3 import exp
from quad_dob_env.trajectories import Reference
from quad_dob_training.rollout import fly

PAPER = get_vehicle("paper")
FORCE, TORQUE, WIND = np.array([1.0, -2.0, 0.5]), np.array([0.05, -0.1, 0.02]), np.array(
    [4.0, -3.0, 0.5])


def _state_vector(core, i):
    s = core.state
    return np.concatenate([s.position[i], s.velocity[i], s.rotation[i].reshape(9),
                           s.angular_velocity[i]])


@pytest.mark.parametrize("actuation", ["wrench", "rotors"])
@pytest.mark.parametrize("motor_lag", [False, True])
def test_one_step_equals_the_oracle_on_random_states(actuation, motor_lag):
    # drag in a constant wind, a constant force and torque, random states and commands
    n = 12
    scenario = make_scenario("hover-calm", actuation=actuation, drag=True, motor_lag=motor_lag,
                             disturbance=Constant(FORCE, TORQUE, WIND), floor_height=None,
                             substeps=16)  # the integrator's truncation far below 1e-9
    core = QuadrotorBatch(scenario, n)
    core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
    rng = np.random.default_rng(4)
    core.state.position[:] = rng.normal(0.0, 1.0, (n, 3)) + np.array([0.0, 0.0, 1.0])
    core.state.velocity[:] = rng.normal(0.0, 3.0, (n, 3))
    core.state.rotation[:] = exp(rng.normal(0.0, 0.6, (n, 3)))
    core.state.angular_velocity[:] = rng.normal(0.0, 2.0, (n, 3))
    start = [_state_vector(core, i) for i in range(n)]
    actions = rng.uniform(-0.8, 0.8, (n, 4))
    thrust, moment = core.action_map.to_command(actions)
    core.step(actions)
    vehicle = oracle.Vehicle.of(PAPER, drag=True, motor_lag=motor_lag)
    environment = oracle.Environment(force=lambda t: FORCE, torque=lambda t: TORQUE,
                                     wind=lambda t: WIND)
    hover = (np.linalg.solve(vehicle.allocation(), [PAPER.hover_thrust, 0, 0, 0])
             if actuation == "rotors" else np.array([PAPER.hover_thrust, 0.0, 0.0, 0.0]))
    for i in range(n):
        command = oracle.mix(vehicle, thrust[i], moment[i], actuation)
        y = oracle.rigid_body_step(np.concatenate([start[i], hover, np.zeros(6)]), 0.0,
                                   scenario.dt, vehicle, environment, actuation, command)
        np.testing.assert_allclose(_state_vector(core, i), y[:18], rtol=0, atol=2e-9,
                                   err_msg=f"vehicle {i}")


@pytest.mark.parametrize("name", ["paper", "crazyflie"])
def test_mixer_equals_the_oracle(name):
    params = get_vehicle(name)
    vehicle = oracle.Vehicle.of(params)
    rng = np.random.default_rng(5)
    n = 400
    # from gentle to far past every limit, yaw included
    thrust = rng.uniform(-0.2, 1.3, n) * params.max_total_thrust
    moment = rng.normal(0.0, 1.0, (n, 3)) * params.moment_limit("rotors") * rng.uniform(
        0.0, 3.0, (n, 1))
    applied = Actuator(params, "rotors").apply(thrust, moment)
    for i in range(n):
        rotors = oracle.mix(vehicle, thrust[i], moment[i], "rotors")
        np.testing.assert_allclose(applied.rotor_thrusts[i], rotors, rtol=0,
                                   atol=1e-9 * params.max_rotor_thrust)
        np.testing.assert_allclose(np.concatenate([[applied.thrust[i]], applied.moment[i]]),
                                   vehicle.allocation() @ rotors, rtol=0,
                                   atol=1e-9 * params.max_total_thrust)


def test_lee_law_equals_the_oracle_on_random_states():
    n = 40
    rng = np.random.default_rng(6)
    state = VehicleState(rng.normal(size=(n, 3)), rng.normal(size=(n, 3)),
                         exp(rng.normal(0.0, 0.5, (n, 3))), rng.normal(size=(n, 3)))
    yaw, yaw_rate, yaw_acceleration = (rng.uniform(-np.pi, np.pi, n), rng.normal(size=n),
                                       rng.normal(size=n))
    along = np.stack([np.cos(yaw), np.sin(yaw), np.zeros(n)], 1)
    across = np.stack([-np.sin(yaw), np.cos(yaw), np.zeros(n)], 1)
    reference = Reference(*[rng.normal(size=(n, 3)) for _ in range(5)], along,
                          yaw_rate[:, None] * across,
                          yaw_acceleration[:, None] * across - (yaw_rate**2)[:, None] * along)
    controller = GeometricController()
    controller.reset(n, PAPER, 0.01)
    thrust, moment = controller.compute(np.zeros(n), state, reference)
    vehicle = oracle.Vehicle.of(PAPER)
    gains = (16.0, 5.6, 8.81, 2.54)  # Lee 2010: kx = 16 m, kv = 5.6 m, kR, kΩ
    for i in range(n):
        ref = tuple(getattr(reference, name)[i] for name in (
            "position", "velocity", "acceleration", "jerk", "snap", "heading", "heading_rate",
            "heading_acceleration"))
        f, m, rd = oracle.lee_command(state.position[i], state.velocity[i], state.rotation[i],
                                      state.angular_velocity[i], ref, vehicle, gains,
                                      np.zeros(3), np.zeros(3))
        assert thrust[i] == pytest.approx(f, rel=1e-12, abs=1e-9)
        np.testing.assert_allclose(controller.diagnostics["desired_rotation"][i], rd,
                                   atol=1e-12)
        # Ωd, Ω̇d by finite differences in the oracle: agreement to their error
        np.testing.assert_allclose(moment[i], m, rtol=1e-6, atol=1e-6)


def _gust(t, amplitude, direction, start, rise, hold):
    """The MIL-F-8785C 1-cosine gust, written again: rise over ``rise`` s, hold, fall."""
    tau = t - start
    if tau <= 0:
        return np.zeros(3)
    if tau < rise:
        share = 0.5 * (1 - math.cos(math.pi * tau / rise))
    elif tau < rise + hold:
        share = 1.0
    else:
        share = 0.5 * (1 + math.cos(math.pi * min((tau - rise - hold) / rise, 1.0)))
    unit = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    return amplitude * share * unit


FAMILIES = {
    # name: (scenario, oracle environment, oracle vehicle options, seconds flown)
    "paper-II (wrench, constant wrench disturbance)": (
        make_scenario("paper-II", duration=3.0),
        oracle.Environment(force=lambda t: np.array([1.3, 2.0, 2.6]),
                           torque=lambda t: 0.6 * np.array([1.3, 2.0, 2.6])), {}, 3.0),
    "hover-step-force (rotors, a step of 0.2 weights)": (
        make_scenario("hover-step-force", initial_position_noise=0.0,
                      initial_attitude_noise=0.0, duration=4.5),
        oracle.Environment(force=lambda t: np.array([0.2 * PAPER.hover_thrust, 0, 0])
                           * (3.0 <= t < 6.0)), {}, 4.5),
    "ground-effect-landing (rotors, the paper's law)": (
        make_scenario("ground-effect-landing", duration=4.0),
        oracle.Environment(ground=(3 / 25, 1.0, PAPER.rotor_radius, 0.0,
                                   PAPER.rotor_radius / 2,
                                   PAPER.rotor_radius * (3 / 25) / (1 - 1 / 1.01))), {}, 4.0),
    "wind (rotors, drag, motor lag, a mean wind and a gust)": (
        make_scenario("hover-calm", initial_position_noise=0.0, initial_attitude_noise=0.0,
                      drag=True, motor_lag=True, duration=3.0,
                      disturbance=Constant(wind=(3.0, -2.0, 0.0))
                      + Gust(4.0, direction=(1.0, 1.0, 0.2), start=0.5, length=8.0,
                             speed=10.0, hold=0.4)),
        oracle.Environment(wind=lambda t: np.array([3.0, -2.0, 0.0])
                           + _gust(t, 4.0, (1.0, 1.0, 0.2), 0.5, 0.8, 0.4)),
        {"drag": True, "motor_lag": True}, 3.0),
}


@pytest.mark.slow
@pytest.mark.parametrize("family", list(FAMILIES))
def test_whole_flights_with_the_observer_equal_the_oracle(family):
    scenario, environment, options, seconds = FAMILIES[family]
    flight = fly(make_controller("geometric-ndob:tuned", PAPER), scenario)[0]
    vehicle = oracle.Vehicle.of(PAPER, **options)
    rates = NonlinearDisturbanceObserver.from_rates(vehicle=PAPER, **TUNED_OBSERVER_RATES)
    observer = oracle.Observer(rates.translational_gain, rates.rotational_gain)
    steps = round(seconds / scenario.dt)
    positions, estimate = oracle.fly(scenario, vehicle, environment, (16.0, 5.6, 8.81, 2.54),
                                     observer, steps, substeps=8)
    # the package's observer is discrete (gains matched to the sampling, thrust direction
    # averaged over each step) and the oracle's continuous: measured, they part by at most
    # 0.3 mm, just after the step of hover-step-force, and converge again
    difference = np.linalg.norm(flight.position[:steps] - positions[:steps], axis=1)
    assert difference.max() < 5e-4, (family, difference.max())
    assert difference[-1] < 1e-4, (family, difference[-1])
    # the observers' last force estimates (ground effect's extra lift included) agree too
    np.testing.assert_allclose(flight.force_estimate[steps - 1], estimate, atol=5e-3)
    # and the error they both leave is far larger than their disagreement
    error = np.linalg.norm(flight.position - flight.reference_position, axis=1)
    assert error.max() > 30 * difference.max()
