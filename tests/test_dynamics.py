import numpy as np
import pytest

from quad_dob_env.dynamics import (
    Actuator,
    VehicleState,
    accelerations,
    integrate,
)
from quad_dob_env.params import get_vehicle
from quad_dob_env.so3 import exp
from quad_dob_env.threads import PARALLEL_MIN_BATCH

PAPER = get_vehicle("paper")
G = PAPER.gravity


def fly(state, steps, thrust=0.0, moment=(0.0, 0.0, 0.0), dt=0.01, substeps=1, **kwargs):
    n = state.n
    thrust = np.full(n, thrust)
    moment = np.tile(moment, (n, 1)).astype(float)
    for _ in range(steps):
        diverged = integrate(state, thrust, moment, PAPER, dt, substeps, **kwargs)
        assert not diverged.any()
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
    samples = np.broadcast_to(force, (1, 3, 3)).copy()
    state = fly(VehicleState.at_rest(1), 100, thrust=PAPER.hover_thrust, force_samples=samples)
    np.testing.assert_allclose(state.velocity[0], force / PAPER.mass * 1.0, rtol=1e-12)


def test_accelerations_follow_the_equations_of_motion():
    rng = np.random.default_rng(3)
    state = VehicleState.at_rest(4)
    state.rotation[:] = exp(rng.normal(size=(4, 3)))
    state.angular_velocity[:] = rng.normal(size=(4, 3))
    thrust, moment = rng.uniform(0, 60, 4), rng.normal(size=(4, 3))
    force, torque = rng.normal(size=(4, 3)), rng.normal(size=(4, 3))
    linear, angular = accelerations(state, thrust, moment, PAPER, force, torque)
    J = PAPER.inertia_matrix
    for i in range(4):
        R, w = state.rotation[i], state.angular_velocity[i]
        expected_linear = (-PAPER.mass * G * np.array([0, 0, 1.0]) + thrust[i] * R[:, 2]
                           + force[i]) / PAPER.mass
        expected_angular = np.linalg.solve(J, -np.cross(w, J @ w) + moment[i] + torque[i])
        np.testing.assert_allclose(linear[i], expected_linear, atol=1e-12)
        np.testing.assert_allclose(angular[i], expected_angular, atol=1e-12)


def test_a_batch_split_across_threads_equals_single_vehicles_bit_for_bit():
    rng = np.random.default_rng(7)
    n = PARALLEL_MIN_BATCH + 5
    big = VehicleState.at_rest(n)
    big.rotation[:] = exp(rng.normal(size=(n, 3)))
    big.angular_velocity[:] = rng.normal(size=(n, 3))
    thrust, moment = rng.uniform(0, 80, n), rng.normal(size=(n, 3))
    singles = [VehicleState(big.position[i:i + 1], big.velocity[i:i + 1],
                            big.rotation[i:i + 1], big.angular_velocity[i:i + 1])
               for i in range(0, n, 37)]
    for _ in range(20):
        integrate(big, thrust, moment, PAPER, 0.01)
        for k, single in zip(range(0, n, 37), singles, strict=True):
            integrate(single, thrust[k:k + 1], moment[k:k + 1], PAPER, 0.01)
    for k, single in zip(range(0, n, 37), singles, strict=True):
        assert np.array_equal(big.rotation[k], single.rotation[0])
        assert np.array_equal(big.position[k], single.position[0])


def test_a_diverging_vehicle_keeps_its_last_finite_state_and_is_flagged():
    state = VehicleState.at_rest(2, (0.0, 0.0, 1.0))
    before = state.copy()
    diverged = integrate(state, np.array([PAPER.hover_thrust, np.inf]), np.zeros((2, 3)),
                         PAPER, 0.01)
    assert diverged.tolist() == [False, True]
    np.testing.assert_array_equal(state.position[1], before.position[1])
    assert np.all(np.isfinite(state.position))


def test_bad_sample_shape_is_named():
    with pytest.raises(ValueError, match=r"2\*substeps\+1"):
        integrate(VehicleState.at_rest(1), np.zeros(1), np.zeros((1, 3)), PAPER, 0.01, 2,
                  force_samples=np.zeros((1, 3, 3)))


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
