"""Piecewise polynomial references as the Crazyflie's firmware flies them: derivatives
against finite differences, the time scale's stretch, rest before and after, and the
trajectory files' rows (quad_dob_env/trajectories/polynomial.py)."""

import numpy as np
import pytest

from quad_dob_env.trajectories import PiecewisePolynomial


def pieces(rng, count=3, order=7):
    return [(float(rng.uniform(0.5, 1.5)), rng.normal(size=(4, order + 1)) * 0.3)
            for _ in range(count)]


def test_each_derivative_is_the_rate_of_the_one_below():
    trajectory = PiecewisePolynomial(pieces(np.random.default_rng(1)), time_scale=1.7,
                                     offset=(0.0, 0.0, 1.0))
    h = 1e-5
    for t in np.linspace(0.1, trajectory.duration - 0.1, 23):
        if np.min(np.abs(trajectory.starts * 1.7 - t)) < 1e-3:
            continue  # a piece boundary: the pieces here are not joined smoothly
        around = trajectory.position_derivatives(np.array([t - h, t + h]))
        here = trajectory.position_derivatives(np.array([t]))
        np.testing.assert_allclose((around[:4, 1] - around[:4, 0]) / (2 * h), here[1:, 0],
                                   rtol=1e-5, atol=1e-5)
        yaw_around, yaw_here = (trajectory.yaw_derivatives(np.array([t - h, t + h])),
                                trajectory.yaw_derivatives(np.array([t])))
        np.testing.assert_allclose((yaw_around[:2, 1] - yaw_around[:2, 0]) / (2 * h),
                                   yaw_here[1:, 0], rtol=1e-5, atol=1e-5)


def test_the_time_scale_stretches_time_and_divides_each_derivative():
    drawn = pieces(np.random.default_rng(2))
    once, slower = PiecewisePolynomial(drawn), PiecewisePolynomial(drawn, time_scale=2.0)
    t = np.linspace(0.0, once.duration, 17)
    scaled, plain = slower.position_derivatives(2.0 * t), once.position_derivatives(t)
    for order in range(5):
        np.testing.assert_allclose(scaled[order], plain[order] / 2.0**order, atol=1e-12)
    assert slower.duration == pytest.approx(2.0 * once.duration)


def test_it_rests_at_its_ends_before_and_after():
    trajectory = PiecewisePolynomial(pieces(np.random.default_rng(3)), offset=(1.0, 2.0, 3.0))
    outside = trajectory.position_derivatives(np.array([-1.0, trajectory.duration + 5]))
    before, after = outside[:, 0], outside[:, 1]
    first, last = trajectory.position_derivatives(np.array([0.0, trajectory.duration]))[0]
    np.testing.assert_allclose(before[0], first)
    np.testing.assert_allclose(after[0], last)
    assert not before[1:].any() and not after[1:].any()
    # the offset is added once, to the position
    bare = PiecewisePolynomial(pieces(np.random.default_rng(3)))
    np.testing.assert_allclose(first - bare.start_position(), [1.0, 2.0, 3.0])


def test_a_trajectory_file_is_read_with_or_without_its_header(tmp_path):
    rows = ["Duration,x^0,x^1,y^0,y^1,z^0,z^1,yaw^0,yaw^1", "1.0,0,1,0,0,0,0,0,0.5",
            "2.0,1,0,0,1,0,0,0.5,0"]
    path = tmp_path / "line.csv"
    path.write_text("\n".join(rows) + "\n")
    trajectory = PiecewisePolynomial.from_csv(path, time_scale=0.5)
    reference = trajectory.evaluate([0.25, 1.0])  # flown twice as fast: 0.5 s and 2 s in
    np.testing.assert_allclose(reference.position, [[0.5, 0.0, 0.0], [1.0, 1.0, 0.0]])
    np.testing.assert_allclose(reference.velocity, [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    (tmp_path / "plain.csv").write_text("\n".join(rows[1:]))
    assert PiecewisePolynomial.from_csv(tmp_path / "plain.csv").duration == 3.0
    (tmp_path / "bad.csv").write_text("1.0,0,1,0,0,0\n")
    with pytest.raises(ValueError, match="row 1 holds 6 numbers"):
        PiecewisePolynomial.from_csv(tmp_path / "bad.csv")
    with pytest.raises(ValueError, match="time_scale"):
        PiecewisePolynomial.from_csv(path, time_scale=0.0)


def test_a_start_time_delays_the_whole_reference():
    parts = pieces(np.random.default_rng(9))
    now = PiecewisePolynomial(parts, time_scale=1.3)
    later = PiecewisePolynomial(parts, time_scale=1.3, start_time=2.5)
    times = np.linspace(0.0, now.duration + 0.5, 17)
    np.testing.assert_allclose(later.position_derivatives(times + 2.5),
                               now.position_derivatives(times), rtol=0, atol=1e-12)
    # before it begins, its start at rest
    before = later.position_derivatives(np.array([0.0, 1.0, 2.4]))
    np.testing.assert_allclose(before[0], np.repeat(now.position_derivatives(
        np.zeros(1))[0], 3, axis=0), atol=1e-12)
    assert np.all(before[1:] == 0.0)
    with pytest.raises(ValueError, match="start_time"):
        PiecewisePolynomial(parts, start_time=-1.0)
