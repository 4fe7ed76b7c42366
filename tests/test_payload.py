"""The cable-suspended payload (``SuspendedPayload``) and the env's ``follow`` hook.

Every oracle here comes from the physics, not from the model's code: the static hang
(T = m g), the pendulum's period, energy and tension, a fine RK4 integration of the same
taut-cable equations behind a vehicle on a circle, and, through the env, the momentum
balance of vehicle plus payload (the cable's force is internal to it).
"""

import math

import numpy as np
import pytest

from quad_dob_env.disturbances import Constant, Disturbance, Sum, SuspendedPayload, Window
from quad_dob_env.envs import QuadrotorEnv
from quad_dob_env.scenarios import make_scenario

MASS, LENGTH, G, DT = 0.005, 0.5, 9.81, 0.002  # Crazyswarm2's 5 g on 0.5 m
UP = np.array([0.0, 0.0, 1.0])


def hung(num_vehicles=1, dt=DT):
    payload = SuspendedPayload(MASS, LENGTH, G)
    payload.bind(num_vehicles, dt)
    payload.resample(np.arange(num_vehicles), [None] * num_vehicles)
    return payload


@pytest.mark.parametrize(("arguments", "field"), [
    ((0.0, LENGTH), "SuspendedPayload.mass"),
    ((MASS, -0.5), "SuspendedPayload.cable_length"),
    ((math.nan, LENGTH), "SuspendedPayload.mass"),
    ((MASS, LENGTH, math.nan), "SuspendedPayload.gravity"),
    (("5 g", LENGTH), "SuspendedPayload.mass"),
])
def test_bad_input_is_refused_naming_the_field(arguments, field):
    with pytest.raises(ValueError, match=field):
        SuspendedPayload(*arguments)


def test_a_payload_under_a_vehicle_held_still_hangs_below_it_and_weighs_on_it():
    payload = hung(2)
    position = np.array([[0.3, -1.0, 2.0], [0.0, 0.0, 1.0]])
    for _ in range(500):
        payload.follow(position, np.zeros((2, 3)))
    np.testing.assert_allclose(payload.position, position - LENGTH * UP, rtol=1e-9)
    np.testing.assert_allclose(payload.velocity, 0.0, atol=1e-12)
    weight = np.tile([0.0, 0.0, -MASS * G], (2, 1))  # static equilibrium: T = m g, downward
    np.testing.assert_allclose(payload.tension, MASS * G, rtol=1e-9)
    force, torque, wind = (np.zeros((2, 5, 3)) for _ in range(3))
    payload.add_to(None, force, torque, wind)  # held over every sample time of the step
    np.testing.assert_allclose(force, np.repeat(weight[:, None], 5, axis=1), rtol=1e-9)
    assert not torque.any() and not wind.any()
    payload.add_to(None, force, torque, wind)  # no follow since: the same force again
    np.testing.assert_allclose(force[:, -1], 2 * weight, rtol=1e-9)


def released_pendulum(amplitude, steps):
    """The payload under a fixed point, released from rest at ``amplitude`` [rad]: its
    states after each step, and the tension of each step with the angle it started at."""
    pivot = np.array([[0.0, 0.0, 1.0]])
    payload = hung()
    payload.follow(pivot, np.zeros((1, 3)))
    payload.position[:] = pivot + LENGTH * np.array(
        [math.sin(amplitude), 0.0, -math.cos(amplitude)])
    payload.velocity[:] = 0.0
    positions, velocities, tensions, cosines = [], [], [], []
    for _ in range(steps):
        below = pivot[0] - payload.position[0]
        cosines.append(below[2] / np.linalg.norm(below))
        payload.follow(pivot, np.zeros((1, 3)))
        positions.append(payload.position[0].copy())
        velocities.append(payload.velocity[0].copy())
        tensions.append(payload.tension[0])
    return pivot[0], np.array(positions), np.array(velocities), np.array(tensions), np.array(
        cosines)


def test_a_released_pendulum_keeps_its_period_energy_and_tension():
    amplitude = math.radians(10.0)
    # the period with its first amplitude correction (Landau-Lifshitz, Mechanics §11)
    period = 2 * math.pi * math.sqrt(LENGTH / G) * (1 + amplitude**2 / 16)
    steps = int(5 * period / DT) + 10
    pivot, positions, velocities, tensions, cosines = released_pendulum(amplitude, steps)
    x = positions[:, 0]
    crossings = np.flatnonzero((x[:-1] > 0.0) & (x[1:] <= 0.0))
    times = (crossings + 1 + x[crossings] / (x[crossings] - x[crossings + 1])) * DT
    assert len(times) >= 5
    assert np.diff(times).mean() == pytest.approx(period, rel=0.01)
    # the swing's energy (from the lowest point, so the hanging weight does not dilute it)
    lowest = pivot[2] - LENGTH
    energy = (0.5 * MASS * (velocities**2).sum(axis=1)
              + MASS * G * (positions[:, 2] - lowest))
    start = MASS * G * LENGTH * (1 - math.cos(amplitude))
    np.testing.assert_allclose(energy, start, rtol=0.01)
    # an inextensible cable: no speed along it (the integrator's residue is O(dt²))
    along = np.einsum("ij,ij->i", positions - pivot, velocities) / LENGTH
    assert np.abs(along).max() < 1e-4
    # the tension from energy and the centripetal balance: T = m g (3 cos θ - 2 cos θ0)
    np.testing.assert_allclose(tensions, MASS * G * (3 * cosines - 2 * math.cos(amplitude)),
                               rtol=0, atol=2e-3 * MASS * G)


def circle(radius, rate, height):
    """A vehicle's position, velocity and acceleration on a level circle, as functions of t."""
    def position(t):
        return np.array([radius * math.cos(rate * t), radius * math.sin(rate * t), height])

    def velocity(t):
        return radius * rate * np.array([-math.sin(rate * t), math.cos(rate * t), 0.0])

    def acceleration(t):
        return -rate**2 * (position(t) - np.array([0.0, 0.0, height]))

    return position, velocity, acceleration


def payload_oracle(position, velocity, acceleration, start, steps, substeps=20):
    """The taut-cable point mass behind a vehicle on a known path, by RK4 at dt/substeps
    with the vehicle's exact acceleration: r̈ = -g e3 - (T/m) q,
    T = m (|ṙ - v|_⊥² / L - g q·e3 - q·a). Its positions after each control step, and
    the tension at each step's start."""
    def tension_along(t, state):
        offset = state[:3] - position(t)
        q = offset / np.linalg.norm(offset)
        relative = state[3:] - velocity(t)
        across = relative - (q @ relative) * q
        return MASS * (across @ across / LENGTH - G * q[2] - q @ acceleration(t)), q

    def derivative(t, state):
        tension, q = tension_along(t, state)
        return np.concatenate([state[3:], -G * UP - tension / MASS * q])

    state, t, h = start.copy(), 0.0, DT / substeps
    out, tensions = [], []
    for _ in range(steps):
        tensions.append(tension_along(t, state)[0])
        for _ in range(substeps):
            k1 = derivative(t, state)
            k2 = derivative(t + h / 2, state + h / 2 * k1)
            k3 = derivative(t + h / 2, state + h / 2 * k2)
            k4 = derivative(t + h, state + h * k3)
            state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            t += h
        out.append(state[:3].copy())
    return np.array(out), np.array(tensions)


def test_behind_a_vehicle_on_a_circle_the_cable_keeps_its_length_and_the_swing_is_right():
    position, velocity, acceleration = circle(radius=0.2, rate=1.5, height=1.0)
    steps = 1500  # 3 s, most of a lap
    payload = hung()
    lengths, tensions, trajectory = [], [], []
    for k in range(steps):
        payload.follow(position(k * DT)[None], velocity(k * DT)[None])
        # the integrated payload against where the vehicle is at the same instant, before
        # the next step puts it back on the cable's sphere
        lengths.append(np.linalg.norm(payload.position[0] - position((k + 1) * DT)))
        tensions.append(payload.tension[0])
        trajectory.append(payload.position[0].copy())
    np.testing.assert_allclose(lengths, LENGTH, rtol=1e-6)
    assert min(tensions) > 0.5 * MASS * G  # taut throughout: never a false slack step
    start = np.concatenate([position(0.0) - LENGTH * UP, velocity(0.0)])
    oracle, oracle_tensions = payload_oracle(position, velocity, acceleration, start, steps)
    swing = np.linalg.norm(oracle[:, :2] - np.array([position((k + 1) * DT)[:2]
                                                      for k in range(steps)]), axis=1)
    assert swing.max() > 0.02  # the payload does swing out (a check with teeth)
    np.testing.assert_allclose(np.array(trajectory), oracle, rtol=0, atol=2e-5)
    # the pull on the vehicle (the model takes the vehicle's acceleration from its last two
    # velocities, the oracle from the path: they differ by O(dt) of the jerk)
    np.testing.assert_allclose(tensions, oracle_tensions, rtol=0, atol=2e-4 * MASS * G)


def test_a_slack_cable_pulls_nothing_and_the_payload_falls_freely():
    payload = hung()
    vehicle = np.array([[0.0, 0.0, 1.0]])
    payload.follow(vehicle, np.zeros((1, 3)))
    payload.position[:] = vehicle - 0.5 * LENGTH * UP  # well inside the cable's reach
    payload.velocity[:] = 0.0
    payload.follow(vehicle, np.zeros((1, 3)))
    assert payload.tension[0] == 0.0
    force = np.zeros((1, 3, 3))
    payload.add_to(None, force, np.zeros_like(force), np.zeros_like(force))
    assert not force.any()
    np.testing.assert_allclose(payload.velocity[0], -G * DT * UP, rtol=1e-12)


class Recorder(Disturbance):
    """Records what ``follow`` is handed; adds nothing."""

    is_random = True
    uses_time = False
    channels = (True, False, False)

    def __init__(self, follows_vehicle=True):
        self.follows_vehicle = follows_vehicle
        self.seen = []

    def follow(self, position, velocity, vehicle_mass=None):
        self.seen.append((np.array(position), np.array(velocity)))

    def add_to(self, times, force, torque, wind):
        # the env must hand the state over before it asks for the force
        assert len(self.seen) > 0 or not self.follows_vehicle


def test_sum_and_window_forward_follow_to_the_models_that_follow():
    follower, other = Recorder(), Recorder(follows_vehicle=False)
    position, velocity = np.ones((1, 3)), np.full((1, 3), 2.0)
    total = follower + other + Constant(force=(1.0, 0.0, 0.0))
    assert isinstance(total, Sum) and total.follows_vehicle
    total.follow(position, velocity)
    assert len(follower.seen) == 1 and not other.seen
    np.testing.assert_array_equal(follower.seen[0][0], position)
    np.testing.assert_array_equal(follower.seen[0][1], velocity)
    assert not (other + Constant(force=(1.0, 0.0, 0.0))).follows_vehicle
    windowed = follower.during(0.0, 1.0)
    assert isinstance(windowed, Window) and windowed.follows_vehicle
    windowed.follow(position, velocity)
    assert len(follower.seen) == 2
    assert not Constant(force=(1.0, 0.0, 0.0)).during(0.0, 1.0).follows_vehicle
    assert SuspendedPayload(MASS, LENGTH).during(0.0, 1.0).follows_vehicle


STILL = {"initial_position_noise": 0.0, "initial_attitude_noise": 0.0}


def payload_flight(disturbance):
    scenario = make_scenario("hover-calm", vehicle="crazyflie", disturbance=disturbance,
                             actuation="wrench", benchmark="v1", **STILL)
    env = QuadrotorEnv(scenario)
    env.reset(seed=0)
    return env


def test_the_env_hands_follow_the_true_state_before_each_step():
    env = payload_flight(Recorder())
    core = env.core
    recorder = core.random_disturbance
    for _ in range(3):
        before = (core.state.position.copy(), core.state.velocity.copy())
        env.step(np.array([0.3, 0.0, 0.0, 0.0]))
        np.testing.assert_array_equal(recorder.seen[-1][0], before[0])
        np.testing.assert_array_equal(recorder.seen[-1][1], before[1])
    assert len(recorder.seen) == 3


def test_through_the_env_vehicle_and_payload_trade_momentum_and_nothing_else():
    """The cable's pull is internal to vehicle plus payload: their total momentum changes
    by the thrust and the weight of both alone, whatever the swing."""
    push = Constant(force=(0.05, 0.0, 0.0)).during(0.0, 0.2)  # sets the payload swinging
    env = payload_flight(SuspendedPayload(MASS, LENGTH) + push)
    core = env.core
    payload = core.random_disturbance
    assert isinstance(payload, SuspendedPayload)  # the env's own copy, evaluated each step
    vehicle_mass, dt = float(core.mass[0]), env.scenario.dt
    action = np.array([0.3, 0.0, 0.0, 0.0])  # climb: thrust above both weights
    env.step(action)
    # the first follow after the reset hung the payload under the vehicle's start
    np.testing.assert_allclose(payload.tension[0], MASS * G, rtol=1e-9)
    for _ in range(19):  # to the push's end, t = 0.2 s
        env.step(action)

    def momentum():
        return vehicle_mass * core.state.velocity[0] + MASS * payload.velocity[0]

    start, payload_start = momentum(), MASS * payload.velocity[0].copy()
    external = np.zeros(3)
    residuals, payload_change = [], []
    for _ in range(100):  # 1 s of swinging
        _, _, terminated, truncated, info = env.step(action)
        assert not (terminated or truncated)
        np.testing.assert_allclose(core.state.rotation[0], np.eye(3), atol=1e-12)
        external += (info["applied_thrust"] * UP - (vehicle_mass + MASS) * G * UP) * dt
        residuals.append(momentum() - start - external)
        payload_change.append(MASS * payload.velocity[0] - payload_start)
    residuals, payload_change = np.array(residuals), np.array(payload_change)
    swing = np.abs(payload_change[:, 0]).max()
    assert swing > 1e-3  # the payload swings: its momentum changes by a good part of itself
    # within a few percent of what the swing moves; a vehicle that did not feel the cable
    # would be off by the payload's own change, one that felt it reversed by twice that
    assert np.abs(residuals[:, 0]).max() < 0.03 * swing
    assert np.abs(residuals[:, 2]).max() < 0.03 * abs(external[2])
    assert external[2] > 0.03  # a climb well away from hover


def test_a_reset_hangs_the_payload_under_the_vehicle_again():
    push = Constant(force=(0.05, 0.0, 0.0)).during(0.0, 0.2)
    env = payload_flight(SuspendedPayload(MASS, LENGTH) + push)
    core, payload = env.core, env.core.random_disturbance
    for _ in range(40):
        env.step(np.array([0.2, 0.0, 0.0, 0.0]))
    assert abs(payload.position[0, 0] - core.state.position[0, 0]) > 1e-3  # swinging
    env.reset(seed=1)
    start = core.state.position[0].copy()
    env.step(np.zeros(4))
    # hung straight down at the reset's start, then one step at rest relative to it
    np.testing.assert_allclose(payload.tension[0], MASS * G, rtol=1e-9)
    np.testing.assert_allclose(payload.position[0, :2], start[:2], atol=1e-12)


@pytest.mark.parametrize("ratio", [0.9, 1.3])
def test_a_payload_about_as_heavy_as_the_vehicle_pulls_smoothly(ratio):
    """The pull is solved with the vehicle's own response to it (T (1 + m_p/M)): read from
    the last step's acceleration alone, T rings at the step rate by -m_p/M a step (0.04 of
    m_p g here at 0.9) and grows once m_p > M (past 4 m_p g within 1 s at 1.3)."""
    vehicle = make_scenario("hover-calm", vehicle="crazyflie").vehicle
    heavy = ratio * vehicle.mass
    push = Constant(force=(0.05, 0.0, 0.0)).during(0.0, 0.2)
    env = payload_flight(SuspendedPayload(heavy, LENGTH) + push)
    payload = env.core.random_disturbance  # the push is no random part
    tensions = []
    for _ in range(100):
        _, _, terminated, truncated, _ = env.step(np.array([1.0, 0.0, 0.0, 0.0]))
        assert not (terminated or truncated)
        tensions.append(payload.tension[0])
    ringing = np.abs(np.diff(tensions[25:], 2)).max()  # a mode at the step rate shows here
    assert ringing < 2e-3 * heavy * G
