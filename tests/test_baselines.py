import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding

import quad_dob_env  # noqa: F401
from quad_dob_baselines import (
    CONTROLLERS,
    GeometricController,
    NonlinearDisturbanceObserver,
    make_controller,
)
from quad_dob_composition import ReferencePolicy
from quad_dob_env.disturbances import Constant
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.flatness import attitude_from_thrust_vector as desired_attitude
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario
from quad_dob_env.so3 import vee
from quad_dob_training.rollout import fly

PAPER = get_vehicle("paper")
FORCE, TORQUE = np.array([1.3, 2.0, 2.6]), np.array([0.78, 1.2, 1.56])


def settled_rms(flight, after=2.0):
    error = np.linalg.norm(flight.position - flight.reference_position, axis=1)
    return float(np.sqrt(np.mean(error[flight.time >= after] ** 2)))


def test_geometric_tracks_the_undisturbed_helix_within_a_centimetre():
    flight = fly(make_controller("geometric"), make_scenario("paper-none"))[0]
    error = np.linalg.norm(flight.position - flight.reference_position, axis=1)
    assert flight.termination_reason == "time_limit"
    assert error[flight.time >= 2.0].max() < 0.01
    assert error[0] == pytest.approx(0.6)  # it really started off the reference


def test_tuned_ndob_cuts_paper_ii_error_by_more_than_90_percent():
    scenario = make_scenario("paper-II")
    without = settled_rms(fly(make_controller("geometric"), scenario)[0])
    with_observer = settled_rms(fly(make_controller("geometric-ndob:tuned"), scenario)[0])
    assert with_observer < 0.1 * without


@pytest.mark.parametrize("name", ["pid", "smc"])
def test_pid_and_smc_fly_the_undisturbed_helix_under_5_cm(name):
    flight = fly(make_controller(name), make_scenario("paper-none"))[0]
    assert flight.termination_reason == "time_limit"
    assert settled_rms(flight) < 0.05


# raptor commands rotors alone, and the paper-* scenarios apply a wrench: its own tests
# (test_raptor.py) fly it on rotor-actuated ones; crazyflie-lee's gains are the Crazyflie
# firmware's, which refuse the 4.34 kg paper vehicle (test_crazyflie_lee.py)
@pytest.mark.parametrize("name", [name for name in CONTROLLERS
                                  if name not in ("raptor", "crazyflie-lee")])
def test_every_controller_stays_bounded_in_every_paper_scenario(name):
    scenarios = [make_scenario(s) for s in ("paper-I", "paper-II", "paper-IIA",
                                            "ground-effect-landing")]
    for flight in fly(make_controller(name), scenarios):
        assert flight.termination_reason == "time_limit", (flight.scenario, name)
        assert settled_rms(flight) < 0.25


def hover_with_observer(observer, force, torque, steps, actuation="wrench"):
    scenario = make_scenario("hover-calm", initial_position_noise=0.0,
                             initial_attitude_noise=0.0, actuation=actuation,
                             disturbance=Constant(force, torque))
    core = QuadrotorBatch(scenario, 1)
    core.reset(np.zeros(1, dtype=np.intp), [seeding.np_random(0)[0]])
    controller = GeometricController(observer=observer)
    controller.reset(1, PAPER, scenario.dt)
    force_error, torque_error, saturated = [], [], []
    for _ in range(steps):
        start = core.state.copy()
        thrust, moment = controller.compute(core.time, core.state, core.reference)
        force_error.append(observer.force_estimate[0] - force)
        torque_error.append(observer.torque_estimate[0] - torque)
        core.step(core.action_map.to_actions(thrust, moment))
        saturated.append(bool(core.applied.saturated[0]))
        controller.applied(start, core.applied.thrust, core.applied.moment)
    return np.array(force_error), np.array(torque_error), np.array(saturated)


def measured_rate(error, first, last, dt=0.01):
    return np.log(np.abs(error[first]) / np.abs(error[last])) / ((last - first) * dt)


@pytest.mark.parametrize(("observer", "window"), [
    (NonlinearDisturbanceObserver.from_rates(5.0, (2.0, 5.0, 10.0), PAPER), (2, 40)),
    (NonlinearDisturbanceObserver(1.0, (0.02, 0.2, 0.05)), (50, 300)),  # paper's Km
])
def test_observer_error_decays_at_ks_over_m_and_km_j_inverse(observer, window):
    translational, rotational = observer.decay_rates(PAPER)
    force_error, _, _ = hover_with_observer(observer, FORCE, np.zeros(3), window[1] + 1)
    np.testing.assert_allclose(measured_rate(force_error, *window), translational, rtol=0.02)
    _, torque_error, _ = hover_with_observer(observer, np.zeros(3), TORQUE, window[1] + 1)
    # J and Km are diagonal here, so each axis decays at its own Km_ii / J_ii
    expected = np.diag(observer.rotational_gain) / np.diag(PAPER.inertia_matrix)
    np.testing.assert_allclose(measured_rate(torque_error, *window), expected, rtol=0.02)
    np.testing.assert_allclose(np.sort(expected), rotational, rtol=1e-12)


def test_paper_observer_gains_are_slow_as_documented():
    translational, rotational = NonlinearDisturbanceObserver().decay_rates(PAPER)
    assert 1 / translational > 200  # seconds: a time constant of minutes
    np.testing.assert_allclose(rotational, [0.2439, 0.3631, 2.3669], rtol=1e-3)


def test_observer_is_fed_what_was_applied_not_what_was_asked():
    # physical rotors make at most 2 c f_max = 0.83 N m of yaw on this vehicle (less at
    # hover thrust): against 1 N m the request saturates, yet the estimate converges because
    # the observer sees what was applied
    yaw_torque = np.array([0.0, 0.0, 1.0])
    observer = NonlinearDisturbanceObserver.from_rates(5.0, 10.0, PAPER)
    _, torque_error, saturated = hover_with_observer(observer, np.zeros(3), yaw_torque, 100,
                                                     actuation="rotors")
    assert saturated[50:].all()
    assert np.abs(torque_error[-1]).max() < 0.02 * yaw_torque[2]


def test_analytic_desired_rate_matches_finite_differences_of_rd():
    errors = []
    for dt in (0.01, 0.005):
        scenario = make_scenario("paper-none", dt=dt)
        core = QuadrotorBatch(scenario, 1)
        core.reset(np.zeros(1, dtype=np.intp), [seeding.np_random(0)[0]])
        controller = make_controller("geometric")
        controller.reset(1, PAPER, dt)
        rotations, rates = [], []
        for _ in range(scenario.steps):
            thrust, moment = controller.compute(core.time, core.state, core.reference)
            rotations.append(controller.diagnostics["desired_rotation"][0].copy())
            rates.append(controller.diagnostics["desired_angular_velocity"][0].copy())
            core.step(core.action_map.to_actions(thrust, moment))
        rd, rates = np.array(rotations), np.array(rates)
        central = vee(np.swapaxes(rd[1:-1], 1, 2) @ (rd[2:] - rd[:-2]) / (2 * dt))
        settled = slice(int(2 / dt), None)
        errors.append(np.abs(central[settled] - rates[1:-1][settled]).max())
    assert errors[0] < 0.02  # rad/s, against |Ωd| up to about 5 rad/s
    assert errors[1] < 0.6 * errors[0]  # shrinks with dt: O(dt) at least


def test_desired_attitude_derivatives_match_finite_differences():
    t = np.linspace(0, 3, 31)
    h = 1e-5

    def at(time):
        force = np.stack([np.sin(time), np.cos(2 * time), 9.81 + 0.5 * np.sin(3 * time)], 1)
        force_dot = np.stack([np.cos(time), -2 * np.sin(2 * time), 1.5 * np.cos(3 * time)], 1)
        force_ddot = np.stack([-np.sin(time), -4 * np.cos(2 * time),
                               -4.5 * np.sin(3 * time)], 1)
        yaw = 0.7 * time
        heading = np.stack([np.cos(yaw), np.sin(yaw), 0 * yaw], 1)
        heading_rate = 0.7 * np.stack([-np.sin(yaw), np.cos(yaw), 0 * yaw], 1)
        return desired_attitude(force, force_dot, force_ddot, heading, heading_rate,
                                -0.49 * heading)

    here, ahead, behind = at(t), at(t + h), at(t - h)
    rd_dot = (ahead.rotation - behind.rotation) / (2 * h)
    np.testing.assert_allclose(vee(np.swapaxes(here.rotation, 1, 2) @ rd_dot),
                               here.angular_velocity, atol=1e-7)
    np.testing.assert_allclose((ahead.angular_velocity - behind.angular_velocity) / (2 * h),
                               here.angular_acceleration, atol=1e-6)


def test_reference_policy_in_gym_make_matches_the_batched_rollout():
    env = gym.make("QuadDOB/Track-v1", scenario="paper-II")
    policy = ReferencePolicy("geometric-ndob:tuned", env)
    obs, _ = env.reset(seed=0)
    positions = []
    for _ in range(300):
        positions.append(env.unwrapped.core.state.position[0].copy())
        action, _ = policy.predict(obs)
        assert env.action_space.contains(action)
        obs, *_ = env.step(action)
    flight = fly(make_controller("geometric-ndob:tuned"), make_scenario("paper-II"))[0]
    # the env's Box(float32) action space rounds the command; the direct rollout does not
    np.testing.assert_allclose(np.array(positions), flight.position[:300], atol=1e-6)
    # a reset restarts the controller (and its observer) too
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs)
    np.testing.assert_allclose(policy.controller.observer.force_estimate, 0.0)


def test_unknown_controller_and_bad_gains_are_named():
    with pytest.raises(ValueError, match=r"valid: geometric, geometric-ndob.*did you mean"):
        make_controller("geometric-dob")
    with pytest.raises(ValueError, match=r"kR must be > 0"):
        make_controller("geometric", kR=-1.0)
    with pytest.raises(ValueError, match="unknown PID gain 'kp'"):
        make_controller("pid", kp=1.0)
    with pytest.raises(ValueError, match=r"rotational_gain .* positive definite"):
        NonlinearDisturbanceObserver(0.02, (0.1, -0.2, 0.1))
    with pytest.raises(ValueError, match="valid: paper, tuned"):
        make_controller("geometric-ndob", gains="fast")


def test_the_geometric_law_record_from_arrays_is_the_one_built_by_keyword():
    # what a compiled caller holding J (3, 3) and a (4, 3) gains table hands geometric_law
    from quad_dob_baselines.geometric_kernels import GeometricLaw, geometric_law_of

    controller = GeometricController(kR=[8.0, 8.5, 9.0])
    controller.reset(1, PAPER, 0.01)
    kx, kv = controller.position_gains
    table = np.stack([kx, kv, controller.gains["kR"], controller.gains["kOmega"]])
    built = geometric_law_of(PAPER.mass, PAPER.gravity, PAPER.inertia_matrix, table)
    expected = GeometricLaw(mass=PAPER.mass, gravity=PAPER.gravity,
                            inertia=tuple(PAPER.inertia_matrix.ravel()), kx=tuple(kx),
                            kv=tuple(kv), k_attitude=(8.0, 8.5, 9.0),
                            k_rate=tuple(controller.gains["kOmega"]))
    assert isinstance(built, GeometricLaw)
    assert built == expected
