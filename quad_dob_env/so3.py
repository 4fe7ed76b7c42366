"""Rotations: batched hat / vee / exponential map / projection onto SO(3).

The public functions take arrays with any leading batch shape. The ``*_tuple`` helpers are
compiled per-vehicle versions on plain float tuples (a rotation is a row-major 9-tuple);
the physics kernel calls them, and ``exp`` runs the same compiled code over a batch, so
the map has one implementation.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

Vec3 = tuple[float, float, float]
Mat3 = tuple[float, float, float, float, float, float, float, float, float]


def _as_vectors(array: ArrayLike, name: str) -> NDArray[np.float64]:
    vectors = np.asarray(array, dtype=float)
    if vectors.ndim == 0 or vectors.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got {vectors.shape}")
    return vectors


def _as_matrices(array: ArrayLike, name: str) -> NDArray[np.float64]:
    matrices = np.asarray(array, dtype=float)
    if matrices.ndim < 2 or matrices.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must have shape (..., 3, 3), got {matrices.shape}")
    return matrices


def cross(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """``a × b`` over the last axis; numpy's ``np.cross`` spends ~50 µs on axis handling."""
    shape = a.shape if a.shape == b.shape else np.broadcast_shapes(a.shape, b.shape)
    out = np.empty(shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def hat(vector: ArrayLike) -> NDArray[np.float64]:
    """Skew-symmetric matrix with ``hat(a) @ b == cross(a, b)``; (..., 3) -> (..., 3, 3)."""
    a = _as_vectors(vector, "hat's argument")
    out = np.zeros((*a.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -a[..., 2], a[..., 1]
    out[..., 1, 0], out[..., 1, 2] = a[..., 2], -a[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -a[..., 1], a[..., 0]
    return out


def vee(matrix: ArrayLike) -> NDArray[np.float64]:
    """Inverse of ``hat`` on the skew part: (..., 3, 3) -> (..., 3)."""
    m = _as_matrices(matrix, "vee's argument")
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]],
        axis=-1,
    )


def exp(rotation_vector: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix ``exp(hat(phi))`` (Rodrigues); (..., 3) -> (..., 3, 3)."""
    phi = _as_vectors(rotation_vector, "exp's argument")
    flat = np.ascontiguousarray(phi.reshape(-1, 3))
    out = np.empty((flat.shape[0], 3, 3))
    _exp_batch(flat, out)
    return out.reshape(*phi.shape[:-1], 3, 3)


def project_to_so3(matrix: ArrayLike) -> NDArray[np.float64]:
    """Nearest rotation in the Frobenius norm (polar decomposition by SVD)."""
    m = _as_matrices(matrix, "project_to_so3's argument")
    u, _, vt = np.linalg.svd(m)
    sign = np.sign(np.linalg.det(u @ vt))
    u[..., :, 2] *= sign[..., None]
    return u @ vt


def tilt_angle(rotation: ArrayLike) -> NDArray[np.float64]:
    """Angle between body +z and world +z, in radians."""
    r = _as_matrices(rotation, "tilt_angle's argument")
    return np.arccos(np.clip(r[..., 2, 2], -1.0, 1.0))


@njit(cache=True, inline="always")
def matrix_entries(a):
    """A 3x3 array as a row-major 9-tuple, the form the compiled equations take."""
    return (a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2], a[2, 0], a[2, 1], a[2, 2])


@njit(cache=True, inline="always")
def transpose_tuple(m: Mat3) -> Mat3:
    return (m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8])


@njit(cache=True, inline="always")
def cross_tuple(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, inline="always")
def mat_vec_tuple(m: Mat3, v: Vec3) -> Vec3:
    return (
        m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
        m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
        m[6] * v[0] + m[7] * v[1] + m[8] * v[2],
    )


@njit(cache=True, inline="always")
def mat_mul_tuple(a: Mat3, b: Mat3) -> Mat3:
    return (
        a[0] * b[0] + a[1] * b[3] + a[2] * b[6],
        a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
        a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
        a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
        a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
        a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
        a[6] * b[0] + a[7] * b[3] + a[8] * b[6],
        a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
        a[6] * b[2] + a[7] * b[5] + a[8] * b[8],
    )


@njit(cache=True)
def exp_tuple(phi: Vec3) -> Mat3:
    """Rodrigues' formula, with Taylor series below 1e-4 rad to keep full precision."""
    x, y, z = phi
    angle_sq = x * x + y * y + z * z
    if angle_sq < 1e-8:
        a = 1.0 - angle_sq / 6.0  # sin(t)/t
        b = 0.5 - angle_sq / 24.0  # (1 - cos t)/t^2
    else:
        angle = math.sqrt(angle_sq)
        a = math.sin(angle) / angle
        b = (1.0 - math.cos(angle)) / angle_sq
    # exp(hat(phi)) = I + a hat(phi) + b hat(phi)^2, hat(phi)^2 = phi phi^T - |phi|^2 I
    return (
        1.0 + b * (x * x - angle_sq), -a * z + b * x * y, a * y + b * x * z,
        a * z + b * x * y, 1.0 + b * (y * y - angle_sq), -a * x + b * y * z,
        -a * y + b * x * z, a * x + b * y * z, 1.0 + b * (z * z - angle_sq),
    )


@njit(cache=True)
def _exp_batch(phi: NDArray, out: NDArray) -> None:
    for i in range(phi.shape[0]):
        r = exp_tuple((phi[i, 0], phi[i, 1], phi[i, 2]))
        for k in range(9):
            out[i, k // 3, k % 3] = r[k]


# --- a batch's rows as tuples, and back: straight-line, since an inlined function with
# an array parameter and a branch or a loop counts the array in and out at every call

@njit(cache=True, inline="always")
def vector_at(array, i):
    """Row i of an (N, 3) array as a 3-tuple."""
    return (array[i, 0], array[i, 1], array[i, 2])


@njit(cache=True, inline="always")
def matrix_at(array, i):
    """Matrix i of an (N, 3, 3) array as a row-major 9-tuple (indexed in full: ``array[i]``
    would make a view, which counts a reference)."""
    return (array[i, 0, 0], array[i, 0, 1], array[i, 0, 2], array[i, 1, 0], array[i, 1, 1],
            array[i, 1, 2], array[i, 2, 0], array[i, 2, 1], array[i, 2, 2])


@njit(cache=True, inline="always")
def store_vector(array, i, value):
    """Write the 3-tuple ``value`` into row i of an (N, 3) array. Straight-line, no loop: an
    inlined function with an array parameter and one block has its reference count pruned,
    one with a loop counts the array in and out at every call (docs/speed.md)."""
    array[i, 0] = value[0]
    array[i, 1] = value[1]
    array[i, 2] = value[2]


@njit(cache=True, inline="always")
def store_matrix(array, i, value):
    """Write the row-major 9-tuple ``value`` into matrix i of an (N, 3, 3) array."""
    array[i, 0, 0], array[i, 0, 1], array[i, 0, 2] = value[0], value[1], value[2]
    array[i, 1, 0], array[i, 1, 1], array[i, 1, 2] = value[3], value[4], value[5]
    array[i, 2, 0], array[i, 2, 1], array[i, 2, 2] = value[6], value[7], value[8]
