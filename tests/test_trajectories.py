import itertools
import math

import numpy as np
import pytest

from quad_dob_env.trajectories import (
    Circle,
    Harmonic,
    Hover,
    Lemniscate,
    PaperHelix,
    RampedStart,
    TakeoffHoverLanding,
)

# Neural-Fly's figure-8, with a turning heading so that the yaw's chain rule is held too
FIGURE8 = Harmonic(offset=(0.0, 0.0, 2.15), terms=[(0, 1.25, 1.0, 0.0), (2, 0.75, 2.0, 0.0)],
                   yaw=0.1, yaw_rate=0.3)

TRAJECTORIES = {
    "paper-helix": PaperHelix(),
    "hover": Hover((1.0, 2.0, 3.0), yaw=0.4),
    "circle": Circle(radius=1.5, period=4.0, yaw=-0.2),
    "lemniscate": Lemniscate(amplitude=2.0, period=6.0),
    "takeoff-landing": TakeoffHoverLanding(climb_time=2.0, hover_time=1.0, descent_time=2.5),
    # the ramp ends at 3 s, between two of the test's samples (φ'' steps there)
    "ramped-figure8": RampedStart(FIGURE8, ramp_time=3.0),
}


def test_paper_helix_is_the_papers_reference():
    t = np.linspace(0, 10, 101)
    ref = PaperHelix().evaluate(t)
    expected = np.stack([0.4 * t, 0.4 * np.sin(np.pi * t), 0.6 * np.cos(np.pi * t)], axis=1)
    np.testing.assert_allclose(ref.position, expected, atol=1e-14)
    np.testing.assert_allclose(ref.heading, np.stack(
        [np.cos(np.pi * t), np.sin(np.pi * t), 0 * t], axis=1), atol=1e-14)


@pytest.mark.parametrize("name", list(TRAJECTORIES))
def test_derivatives_match_finite_differences(name):
    trajectory = TRAJECTORIES[name]
    t = np.linspace(0.05, 6.95, 200)
    h = 1e-5
    here, ahead, behind = (trajectory.evaluate(t + d) for d in (0.0, h, -h))
    chain = ["position", "velocity", "acceleration", "jerk", "snap"]
    for lower, higher in itertools.pairwise(chain):
        central = (getattr(ahead, lower) - getattr(behind, lower)) / (2 * h)
        scale = max(1.0, np.abs(getattr(here, higher)).max())
        np.testing.assert_allclose(central, getattr(here, higher), atol=2e-6 * scale,
                                   err_msg=f"{name}: d/dt {lower} != {higher}")
    for lower, higher in (("heading", "heading_rate"), ("heading_rate", "heading_acceleration")):
        central = (getattr(ahead, lower) - getattr(behind, lower)) / (2 * h)
        np.testing.assert_allclose(central, getattr(here, higher), atol=1e-6,
                                   err_msg=f"{name}: d/dt {lower} != {higher}")


def test_takeoff_landing_is_c3_and_reaches_its_heights():
    trajectory = TakeoffHoverLanding(start_height=0.0, hover_height=1.0, end_height=0.2,
                                     climb_time=2.0, hover_time=1.0, descent_time=2.0)
    ref = trajectory.evaluate(np.array([0.0, 2.0, 2.5, 5.0, 9.0]))
    np.testing.assert_allclose(ref.position[:, 2], [0.0, 1.0, 1.0, 0.2, 0.2], atol=1e-15)
    # continuity of velocity, acceleration and jerk across every segment boundary
    for boundary in (2.0, 3.0, 5.0):
        left, right = (trajectory.evaluate([boundary + d]) for d in (-1e-9, 1e-9))
        for field in ("velocity", "acceleration", "jerk"):
            np.testing.assert_allclose(getattr(left, field), getattr(right, field), atol=1e-5)


def test_heading_is_a_horizontal_unit_vector():
    ref = PaperHelix().evaluate(np.linspace(0, 10, 77))
    np.testing.assert_allclose(np.linalg.norm(ref.heading, axis=1), 1.0, atol=1e-15)
    assert not ref.heading[:, 2].any()


def test_circle_has_its_radius_and_period():
    c = Circle(center=(1.0, 0.0, 2.0), radius=1.5, period=4.0)
    ref = c.evaluate(np.linspace(0, 4, 9))
    np.testing.assert_allclose(np.linalg.norm(ref.position[:, :2] - [1.0, 0.0], axis=1), 1.5)
    np.testing.assert_allclose(ref.position[0], ref.position[-1], atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(ref.velocity, axis=1), 1.5 * 2 * math.pi / 4)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match=r"Circle.radius must be > 0"):
        Circle(radius=-1.0)
    with pytest.raises(ValueError, match=r"Hover.offset must be a finite 3-vector"):
        Hover((0.0, 1.0))
    with pytest.raises(ValueError, match="1-D"):
        Hover().evaluate(np.zeros((2, 2)))


def test_a_ramped_start_leaves_from_rest_and_flies_its_base_late_by_half_the_ramp():
    ramp = 4 * math.pi
    ramped = RampedStart(FIGURE8, ramp)
    start = ramped.evaluate(0.0)
    np.testing.assert_array_equal(start.velocity, 0.0)
    np.testing.assert_array_equal(start.position, FIGURE8.evaluate(0.0).position)
    # after the ramp: the base, half a ramp late, every derivative
    t = np.linspace(ramp, ramp + 20.0, 50)
    late, base = ramped.evaluate(t), FIGURE8.evaluate(t - ramp / 2)
    for name in ("position", "velocity", "acceleration", "jerk", "snap", "heading",
                 "heading_rate", "heading_acceleration"):
        np.testing.assert_allclose(getattr(late, name), getattr(base, name), rtol=0,
                                   atol=1e-12, err_msg=name)
    # during it: the base at φ = t² / 2T, its speed scaled by φ' = t / T
    t = np.linspace(0.1, ramp - 0.1, 40)
    during, base = ramped.evaluate(t), FIGURE8.evaluate(t ** 2 / (2 * ramp))
    np.testing.assert_allclose(during.position, base.position, rtol=0, atol=1e-14)
    np.testing.assert_allclose(during.velocity, base.velocity * (t / ramp)[:, None], rtol=0,
                               atol=1e-14)
    # continuous through its end, position and velocity
    edge = ramped.evaluate(np.array([ramp - 1e-9, ramp]))
    np.testing.assert_allclose(edge.position[0], edge.position[1], atol=1e-8)
    np.testing.assert_allclose(edge.velocity[0], edge.velocity[1], atol=1e-8)


def test_the_tunnel_figure8_ramps_as_neural_flys_logs_and_only_when_asked():
    from quad_dob_env import make_scenario
    from quad_dob_env.wind_tunnel import NEURAL_FLY_RAMP

    plain = make_scenario("figure8-wind-8.5")
    assert type(plain.trajectory) is Harmonic  # v1-v3's figure-8, as it always was
    ramped = make_scenario("figure8-wind-8.5", reference_ramp=NEURAL_FLY_RAMP)
    assert ramped.initial_velocity == (0.0, 0.0, 0.0)
    # the logs' phase rate: 0.0796 t rad/s to 1 rad/s at 12.5 s, from |v_d| on the figure
    t = np.array([1.0, 5.0, 10.0, 12.0, 14.0, 20.0])
    reference = ramped.trajectory.evaluate(t)
    phase = t ** 2 / (2 * NEURAL_FLY_RAMP)
    phase = np.where(t < NEURAL_FLY_RAMP, phase, t - NEURAL_FLY_RAMP / 2)
    shape = np.hypot(1.25 * np.cos(phase), 1.5 * np.cos(2 * phase))
    rate = np.linalg.norm(reference.velocity, axis=1) / shape
    np.testing.assert_allclose(rate, np.minimum(0.0796 * t, 1.0), rtol=2e-3)
    with pytest.raises(ValueError, match="reference_ramp"):
        make_scenario("figure8-wind-8.5", reference_ramp=-1.0)
