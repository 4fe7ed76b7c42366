"""The Crazyflie firmware's Lee law (``crazyflie-lee``) against an oracle written here from
the firmware's equations (IMRCLab crazyflie-firmware ``controller_lee.c``, read term by term;
no code shared with ``geometric_kernels``), over several steps so both integrals count."""

from __future__ import annotations

import math

import numpy as np
import pytest

from quad_dob_baselines import make_controller
from quad_dob_baselines.crazyflie_lee import FirmwareLeeController, FirmwareLeeGains
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VEHICLES
from quad_dob_env.trajectories import Reference

VEHICLE = VEHICLES["crazyflie-2.1"]
GAINS = FirmwareLeeGains(kpos_i=(3.0, 4.0, 10.0))  # every position integral on
DT = 0.002
GRAVITY = 9.81


def rodrigues(vector: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(vector))
    if angle == 0.0:
        return np.eye(3)
    k = np.array([[0, -vector[2], vector[1]], [vector[2], 0, -vector[0]],
                  [-vector[1], vector[0], 0]]) / angle
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


class FirmwareOracle:
    """controller_lee.c for one vehicle, in numpy: its variables, its order of updates."""

    def __init__(self, gains: FirmwareLeeGains, inertia: np.ndarray) -> None:
        self.g, self.J = gains, np.diag(inertia)
        self.i_error_pos, self.i_error_att = np.zeros(3), np.zeros(3)

    def step(self, p, v, tilt, omega, p_d, v_d, a_d, jerk, yaw):
        """The firmware's thrust and moment, the vehicle at R = R_des exp(tilt^) (and R)."""
        g = self.g
        pos_e, vel_e = p_d - p, v_d - v
        self.i_error_pos = self.i_error_pos + DT * pos_e
        F_d = (a_d + np.array([0, 0, GRAVITY]) + np.multiply(g.kpos_d, vel_e)
               + np.multiply(g.kpos_p, pos_e) + np.multiply(g.kpos_i, self.i_error_pos))
        zdes = F_d / np.linalg.norm(F_d)
        xc = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        ydes = np.cross(zdes, xc)
        ydes /= np.linalg.norm(ydes)
        xdes = np.cross(ydes, zdes)
        R_des = np.column_stack([xdes, ydes, zdes])
        R = R_des @ rodrigues(tilt)
        thrust = g.mass * F_d @ R[:, 2]
        eRM = R_des.T @ R - R.T @ R_des
        eR = 0.5 * np.array([eRM[2, 1], eRM[0, 2], eRM[1, 0]])
        hw = g.mass / thrust * (jerk - (zdes @ jerk) * zdes)
        omega_des = np.array([-hw @ ydes, hw @ xdes, 0.0])  # a constant yaw
        omega_r = R.T @ R_des @ omega_des
        self.i_error_att = self.i_error_att + DT * eR
        moment = (-np.multiply(g.kr, eR) - np.multiply(g.kw, omega - omega_r)
                  - np.multiply(g.ki, self.i_error_att) + np.cross(omega, self.J @ omega))
        return thrust, moment, R


# Without jerk both Ωd vanish and the law is the firmware's to rounding, tilted 0.05 rad
# off Rd (where KI dt eR, the attitude integral's newest term, is 1 % of KR eR); with jerk
# the firmware's Ωd divides it by f = m F_d · R e3 where geometric_law's flatness divides by
# |F| (stated in crazyflie_lee): equal to second order in the tilt, so 1e-3 rad there, and
# about z its Ωd is the yaw rate times z_d · e3 where Lee's construction adds b3's turn
@pytest.mark.parametrize("jerk_size, tilt, tolerance, axes", [(0.0, 0.05, 1e-9, 3),
                                                             (3.0, 1e-3, 2e-4, 2)])
def test_the_law_is_the_firmware_s_over_steps(jerk_size, tilt, tolerance, axes):
    rng = np.random.default_rng(5)
    controller = FirmwareLeeController(GAINS)
    controller.reset(1, VEHICLE, DT)
    oracle = FirmwareOracle(GAINS, np.diag(VEHICLE.inertia_matrix))
    yaw = 0.3
    for step in range(6):
        p_d = np.array([0.2, -0.1, 1.0]) + 0.01 * step
        v_d, a_d = rng.normal(0, 0.5, 3), rng.normal(0, 1.0, 3)
        jerk = rng.normal(0, 1.0, 3) * jerk_size
        p, v = p_d + rng.normal(0, 0.03, 3), v_d + rng.normal(0, 0.1, 3)
        omega = rng.normal(0, 0.5, 3)
        *expected, R = oracle.step(p, v, rng.normal(0, tilt, 3), omega, p_d, v_d, a_d, jerk,
                                   yaw)
        state = VehicleState(p[None], v[None], R[None], omega[None])
        heading = np.array([[math.cos(yaw), math.sin(yaw), 0.0]])
        reference = Reference(p_d[None], v_d[None], a_d[None], jerk[None], np.zeros((1, 3)),
                              heading, np.zeros((1, 3)), np.zeros((1, 3)))
        thrust, moment = controller.compute(np.array([step * DT]), state, reference)
        controller.applied(state, thrust, moment)
        np.testing.assert_allclose(thrust[0], expected[0], rtol=1e-9)
        scale = np.abs(expected[1]).max()
        np.testing.assert_allclose(moment[0, :axes], expected[1][:axes], rtol=0,
                                   atol=tolerance * scale)


def test_the_yaw_moment_is_the_firmware_s_without_a_turning_thrust():
    controller = FirmwareLeeController(GAINS)
    controller.reset(1, VEHICLE, DT)
    oracle = FirmwareOracle(GAINS, np.diag(VEHICLE.inertia_matrix))
    rng = np.random.default_rng(8)
    for step in range(4):
        p_d = np.array([0.0, 0.0, 1.0])
        omega = rng.normal(0, 0.5, 3)
        zero = np.zeros(3)
        *expected, R = oracle.step(p_d, zero, np.array([0.0, 0.0, 0.2]), omega, p_d, zero,
                                   zero, zero, 0.1)
        state = VehicleState(p_d[None], zero[None], R[None], omega[None])
        reference = Reference(p_d[None], *(np.zeros((1, 3)),) * 4,
                              np.array([[math.cos(0.1), math.sin(0.1), 0.0]]),
                              np.zeros((1, 3)), np.zeros((1, 3)))
        thrust, moment = controller.compute(np.array([step * DT]), state, reference)
        controller.applied(state, thrust, moment)
        np.testing.assert_allclose(moment[0], expected[1], rtol=1e-9, atol=1e-15)


def test_a_second_compute_before_the_step_integrates_nothing():
    controller = FirmwareLeeController(GAINS)
    controller.reset(1, VEHICLE, DT)
    state = VehicleState(np.array([[0.0, 0.0, 0.9]]), np.zeros((1, 3)), np.eye(3)[None],
                         np.zeros((1, 3)))
    reference = Reference(np.array([[0.0, 0.0, 1.0]]), *(np.zeros((1, 3)),) * 4,
                          np.array([[1.0, 0.0, 0.0]]), np.zeros((1, 3)), np.zeros((1, 3)))
    first = controller.compute(np.zeros(1), state, reference)
    again = controller.compute(np.zeros(1), state, reference)
    np.testing.assert_array_equal(first[0], again[0])
    np.testing.assert_allclose(controller.position_integral, [[0.0, 0.0, 0.1 * DT]],
                               rtol=1e-12)


def test_the_told_mass_sets_the_thrust_not_the_vehicle_s():
    controller = FirmwareLeeController(FirmwareLeeGains(mass=0.05))
    controller.reset(1, VEHICLE, DT)
    state = VehicleState(np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 3)), np.eye(3)[None],
                         np.zeros((1, 3)))
    reference = Reference(np.array([[0.0, 0.0, 1.0]]), *(np.zeros((1, 3)),) * 4,
                          np.array([[1.0, 0.0, 0.0]]), np.zeros((1, 3)), np.zeros((1, 3)))
    thrust, _ = controller.compute(np.zeros(1), state, reference)
    assert thrust[0] == pytest.approx(0.05 * GRAVITY)


def test_gains_from_the_info_file_s_names():
    info = {f"{prefix}{axis}": value for prefix, value in (
        ("Kpos_P", 17.0), ("Kpos_D", 7.0), ("Kpos_I", 32.0), ("KR_", 0.009), ("KI_", 0.05),
        ("Kw_", 0.00125)) for axis in "xyz"} | {"mass": 0.032}
    gains = FirmwareLeeGains.from_parameters(info)
    assert gains.kpos_i == (32.0, 32.0, 32.0) and gains.kw == (0.00125,) * 3
    with pytest.raises(ValueError, match="Kpos_Dy"):
        FirmwareLeeGains.from_parameters({k: v for k, v in info.items() if k != "Kpos_Dy"})


@pytest.mark.parametrize("field, value", [("kpos_p", (1.0, 0.0, 1.0)), ("kw", (1.0, 2.0)),
                                          ("mass", float("nan")), ("kpos_i", (-1.0, 0, 0))])
def test_bad_gains_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=field):
        FirmwareLeeGains(**{field: value})


def test_made_by_name_with_the_default_gains():
    controller = make_controller("crazyflie-lee", "crazyflie-2.1", "v2")
    assert isinstance(controller, FirmwareLeeController)
    assert controller.firmware_gains == FirmwareLeeGains()


def test_another_vehicle_class_is_refused_with_the_way_out():
    controller = FirmwareLeeController()
    with pytest.raises(ValueError, match=r"crazyflie-2\.1"):
        controller.reset(1, VEHICLES["paper"], DT)
    assert controller.refusal(DT, "rotors", VEHICLES["crazyflie-2.1"]) is None


def test_it_flies_the_crazyflie_in_its_loop():
    """The firmware's law holds the crazyflie-2.1 in the Crazyflie's loop (500 Hz, mocap,
    72 ms motors) within 5 cm through a 0.5 m move at time scale 2."""
    from quad_dob_composition import make_vector_env
    from quad_dob_env.crazyflie_loop import CONTROL_PERIOD, loop_options
    from quad_dob_env.loop_options import LoopOptions
    from quad_dob_env.scenario import Scenario
    from quad_dob_env.trajectories.polynomial import PiecewisePolynomial

    move = [0.0, 0.0, 0.0, 10.0, -15.0, 6.0, 0.0, 0.0]  # 0 -> 1 m in 1 s, at rest at both ends
    pieces = [(1.0, np.array([np.multiply(move, 0.5), np.zeros(8),
                              [1.0] + [0.0] * 7, np.zeros(8)]))]
    scenario = Scenario(name="crazyflie-move", vehicle=VEHICLE,
                        trajectory=PiecewisePolynomial(pieces, 2.0, start_time=3.0),
                        duration=8.0, initial_position=(0.0, 0.0, 1.0), dt=CONTROL_PERIOD,
                        loop=LoopOptions(**loop_options()))
    env = make_vector_env(2, scenario, base_controller=FirmwareLeeController())
    _, info = env.reset(seed=[0, 1])
    worst = np.zeros(2)
    for _ in range(round(8.0 / CONTROL_PERIOD) - 1):
        _, _, terminated, _, info = env.step(np.zeros((2, 4)))
        assert not terminated.any()
        worst = np.maximum(worst, np.linalg.norm(info["position_error"], axis=1))
    assert np.all(worst < 0.05)
    np.testing.assert_allclose(info["reference_position"][0], [0.5, 0.0, 1.0], atol=1e-9)
