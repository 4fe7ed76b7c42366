import numpy as np
import pytest
from gymnasium.utils import seeding

from quad_dob_env.disturbances import Constant
from quad_dob_env.dynamics import Actuator, VehicleState
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.params import get_vehicle
from quad_dob_env.scenarios import make_scenario

PAPER = get_vehicle("paper")
G = PAPER.gravity


def fly(state, steps, thrust=0.0, moment=(0.0, 0.0, 0.0), dt=0.01, substeps=1,
        disturbance=None):
    """Fly ``state`` in place through the package's own step (``QuadrotorBatch``, the kernel
    every env runs) with the wrench held, directly applied, no floor."""
    n = state.n
    scenario = make_scenario("hover-calm", actuation="wrench", floor_height=None,
                             initial_position_noise=0.0, initial_attitude_noise=0.0, dt=dt,
                             substeps=substeps, duration=dt, disturbance=disturbance)
    core = QuadrotorBatch(scenario, n)
    core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
    core.state.assign(state)
    actions = core.action_map.to_actions(np.full(n, float(thrust)),
                                         np.tile(np.asarray(moment, float), (n, 1)))
    for _ in range(steps):
        core.step(actions)
        assert not np.any(core.termination_code == 4)  # no step diverged
    state.assign(core.state)
    return state


def test_free_fall_matches_minus_g_exactly():
    state = fly(VehicleState.at_rest(1, (0.0, 0.0, 100.0)), steps=300)
    t = 3.0
    # RK4 integrates a constant acceleration exactly: only round-off remains
    np.testing.assert_allclose(state.velocity[0], [0, 0, -G * t], rtol=0, atol=1e-11)
    np.testing.assert_allclose(state.position[0], [0, 0, 100.0 - G * t**2 / 2], rtol=0,
                               atol=1e-10)


def test_hover_thrust_holds_position_for_ten_seconds():
    state = fly(VehicleState.at_rest(1, (1.0, -2.0, 3.0)), steps=1000, thrust=PAPER.hover_thrust)
    assert np.abs(state.position[0] - [1.0, -2.0, 3.0]).max() < 1e-9
    assert np.abs(state.velocity[0]).max() < 1e-9


def torque_free_spin(dt, seconds=10.0, rate=(0.4, 2.0, -0.7)):
    state = VehicleState.at_rest(1)
    state.angular_velocity[0] = rate
    return fly(state, round(seconds / dt), dt=dt)


def energy_and_momentum(state):
    J, w = PAPER.inertia_matrix, state.angular_velocity[0]
    return 0.5 * w @ J @ w, state.rotation[0] @ J @ w  # momentum in the world frame


def test_torque_free_spin_conserves_energy_and_angular_momentum():
    start = VehicleState.at_rest(1)
    start.angular_velocity[0] = (0.4, 2.0, -0.7)
    energy0, momentum0 = energy_and_momentum(start)
    energy, momentum = energy_and_momentum(torque_free_spin(0.01))
    assert abs(energy - energy0) / energy0 < 1e-6
    assert np.abs(momentum - momentum0).max() / np.linalg.norm(momentum0) < 1e-6
    # the body really tumbled: the conservation is not trivial
    assert np.abs(start.rotation[0] - torque_free_spin(0.01).rotation[0]).max() > 0.5


def test_integrator_is_fourth_order():
    reference = torque_free_spin(0.00125, seconds=2.0).rotation[0]
    errors = [np.abs(torque_free_spin(dt, 2.0).rotation[0] - reference).max()
              for dt in (0.04, 0.02, 0.01)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(13 < r < 19 for r in ratios), (errors, ratios)  # 2^4 = 16


@pytest.mark.slow
def test_rotation_stays_orthonormal_over_100k_steps():
    state = VehicleState.at_rest(1)
    state.angular_velocity[0] = (0.4, 2.0, -0.7)
    fly(state, 100_000, moment=(0.01, -0.02, 0.005))
    R = state.rotation[0]
    assert np.abs(R @ R.T - np.eye(3)).max() < 1e-10


def test_substeps_agree_with_a_finer_step():
    coarse = VehicleState.at_rest(1)
    coarse.angular_velocity[0] = (1.0, -2.0, 0.5)
    fine = coarse.copy()
    fly(coarse, 100, thrust=50.0, moment=(0.1, 0.0, 0.0), dt=0.01, substeps=4)
    fly(fine, 400, thrust=50.0, moment=(0.1, 0.0, 0.0), dt=0.0025)
    np.testing.assert_allclose(coarse.position, fine.position, atol=1e-12)
    np.testing.assert_allclose(coarse.rotation, fine.rotation, atol=1e-12)


def test_constant_disturbance_force_accelerates_by_f_over_m():
    force = np.array([1.3, 2.0, 2.6])
    state = fly(VehicleState.at_rest(1), 100, thrust=PAPER.hover_thrust,
                disturbance=Constant(force=force))
    np.testing.assert_allclose(state.velocity[0], force / PAPER.mass * 1.0, rtol=1e-12)


def test_state_shapes_are_validated():
    with pytest.raises(ValueError, match="same N"):
        VehicleState(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((1, 3, 3)), np.zeros((2, 3)))


class TestActuator:
    def test_feasible_command_passes_unchanged(self):
        applied = Actuator(PAPER, "rotors").apply([PAPER.hover_thrust], [[0.5, -0.3, 0.01]])
        np.testing.assert_allclose(applied.thrust, [PAPER.hover_thrust], atol=1e-12)
        np.testing.assert_allclose(applied.moment, [[0.5, -0.3, 0.01]], atol=1e-12)
        assert not applied.saturated[0]

    def test_rotor_saturation_returns_what_was_applied(self):
        applied = Actuator(PAPER, "rotors").apply([200.0, -5.0], [[0, 0, 1.0], [0, 0, 0]])
        assert applied.saturated.tolist() == [True, True]
        assert applied.rotor_thrusts.min() >= 0
        assert applied.rotor_thrusts.max() <= PAPER.max_rotor_thrust
        # what is reported applied is exactly what those rotor thrusts make
        wrench = applied.rotor_thrusts @ PAPER.allocation_matrix.T
        np.testing.assert_allclose(wrench[:, 0], applied.thrust, atol=1e-12)
        np.testing.assert_allclose(wrench[:, 1:], applied.moment, atol=1e-12)
        assert applied.thrust[0] <= 4 * PAPER.max_rotor_thrust
        assert applied.thrust[1] == 0.0
        # yaw authority is the rotors' drag torque: far below the 1 N m asked for
        assert applied.moment[0, 2] <= 2 * PAPER.torque_coefficient * PAPER.max_rotor_thrust + 1e-12

    def test_wrench_actuation_clips_thrust_and_each_moment(self):
        act = Actuator(PAPER, "wrench")
        applied = act.apply([500.0], [[100.0, -1.0, -100.0]])
        assert applied.thrust[0] == PAPER.max_total_thrust
        np.testing.assert_array_equal(applied.moment[0], [act.moment_limit[0], -1.0,
                                                          -act.moment_limit[2]])
        assert applied.saturated[0]

    def test_unknown_actuation_is_named(self):
        with pytest.raises(ValueError, match="valid: rotors, wrench"):
            Actuator(PAPER, "motors")
