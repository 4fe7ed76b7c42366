"""Small dense linear algebra the package needs and numpy lacks (imports nothing from it)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def expm(matrix: NDArray) -> NDArray[np.float64]:
    """Matrix exponential of a small matrix: scaling and squaring of a Taylor series."""
    matrix = np.asarray(matrix, dtype=float)
    norm = np.abs(matrix).sum(axis=1).max()
    squarings = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0.5 else 0
    scaled = matrix / 2**squarings
    result, term = np.eye(len(matrix)), np.eye(len(matrix))
    for k in range(1, 18):
        term = term @ scaled / k
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result


def discretize_noise(a: NDArray, b: NDArray, dt: float) -> tuple[NDArray, NDArray]:
    """Exact sampling of ``x' = A x + B n`` (n unit white noise) every ``dt``: the transition
    ``Φ = e^{A dt}`` and the noise covariance ``∫ e^{Aτ} B Bᵀ e^{Aᵀτ} dτ`` (Van Loan 1978)."""
    n = len(a)
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n], block[:n, n:], block[n:, n:] = -a, b @ b.T, a.T
    exponential = expm(block * dt)
    transition = exponential[n:, n:].T
    return transition, transition @ exponential[:n, n:]


def stationary_covariance(transition: NDArray, noise: NDArray) -> NDArray[np.float64]:
    """P solving ``P = Φ P Φᵀ + Q`` (a stable discrete Lyapunov equation)."""
    n = len(transition)
    vector = np.linalg.solve(np.eye(n * n) - np.kron(transition, transition), noise.reshape(-1))
    return vector.reshape(n, n)
