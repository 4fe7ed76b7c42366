import itertools
import math

import numpy as np
import pytest

from quad_dob_env.trajectories import (
    Circle,
    Hover,
    Lemniscate,
    PaperHelix,
    TakeoffHoverLanding,
)

TRAJECTORIES = {
    "paper-helix": PaperHelix(),
    "hover": Hover((1.0, 2.0, 3.0), yaw=0.4),
    "circle": Circle(radius=1.5, period=4.0, yaw=-0.2),
    "lemniscate": Lemniscate(amplitude=2.0, period=6.0),
    "takeoff-landing": TakeoffHoverLanding(climb_time=2.0, hover_time=1.0, descent_time=2.5),
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
