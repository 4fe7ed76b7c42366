import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from quad_dob_env import so3

vectors = arrays(np.float64, (5, 3), elements=st.floats(-4, 4))


@given(vectors, vectors)
def test_hat_is_the_cross_product_and_vee_inverts_it(a, b):
    np.testing.assert_allclose(np.einsum("nij,nj->ni", so3.hat(a), b), np.cross(a, b),
                               atol=1e-12)
    np.testing.assert_allclose(so3.vee(so3.hat(a)), a, atol=0)


@given(vectors)
def test_exp_is_a_rotation_about_its_axis(phi):
    R = so3.exp(phi)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape),
                               atol=1e-13)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-13)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", R, phi), phi, atol=1e-12)


def test_exp_matches_the_series_for_tiny_and_moderate_angles():
    for scale in (1e-9, 1e-5, 1e-3, 0.5, 3.0):
        phi = scale * np.array([0.3, -0.5, 0.8])
        K = so3.hat(phi)
        series, term = np.eye(3), np.eye(3)
        for k in range(1, 40):
            term = term @ K / k
            series = series + term
        np.testing.assert_allclose(so3.exp(phi), series, atol=1e-15, rtol=1e-14)


def test_exp_keeps_batch_shape():
    assert so3.exp(np.zeros((2, 4, 3))).shape == (2, 4, 3, 3)


def test_projection_returns_the_nearest_rotation():
    rng = np.random.default_rng(0)
    R = so3.exp(rng.normal(size=(10, 3)))
    noisy = R + 1e-3 * rng.normal(size=R.shape)
    P = so3.project_to_so3(noisy)
    np.testing.assert_allclose(P @ np.swapaxes(P, -1, -2), np.broadcast_to(np.eye(3), P.shape),
                               atol=1e-13)
    assert np.abs(P - R).max() < 1e-2
    reflected = np.diag([1.0, 1.0, -1.0])  # det -1: the nearest rotation has det +1
    assert np.linalg.det(so3.project_to_so3(reflected)) > 0


def test_bad_shapes_are_named():
    import pytest

    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
        so3.hat(np.zeros(4))
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3, 3\)"):
        so3.vee(np.zeros((2, 3)))
