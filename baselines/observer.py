"""Nonlinear disturbance observer (Chen 2000 form) for both translation and rotation.

Continuous form (docs/design.md):
``d̂x = zx + Ks v``, ``żx = -(Ks/m)(zx + Ks v - m g e3 + f R e3)``;
``d̂Ω = zΩ + Km Ω``, ``żΩ = -Km J⁻¹(zΩ + Km Ω - Ω × JΩ + M)``.
Substituting the dynamics gives the estimate error dynamics
``d/dt (d̂x - d_x) = -(Ks/m)(d̂x - d_x)`` and ``d/dt (d̂Ω - d_Ω) = -Km J⁻¹ (d̂Ω - d_Ω)``
for constant disturbances: the error decays at the rate ``Ks/m`` [1/s] in translation and
with the eigenvalues of ``Km J⁻¹`` in rotation.

The paper's gains on the paper vehicle: ``Ks/m = 0.02/4.34 = 0.0046 /s``, a time constant
of 217 s (minutes: over a 10 s flight the translational estimate barely moves), and
``Km J⁻¹ = (0.244, 2.37, 0.363) /s`` (time constants 4.1, 0.42 and 2.75 s).

Discrete time: z is advanced by forward Euler at the control rate with the gains matched to
the sampling, ``Ks' = m (1 - e^{-L dt}) / dt`` (and ``Km' = (I - e^{-L_Ω dt}) J / dt``), and
with the thrust direction R e3 and the gyroscopic torque averaged over each step's two ends.
A constant disturbance is then the fixed point, and the error decays as ``e^{-L t}`` at the
samples. The observer is fed the thrust and moment actually applied. The per-vehicle
equations are compiled in ``quad_dob_baselines.geometric_kernels`` (``observer_*_batch``).

``GivenDisturbance`` takes the observer's place where the estimate is given, not made: the
truth-fed row (``oracle:NAME``) feeds it the simulator's true disturbance.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from quad_dob_baselines.geometric_kernels import observer_advance_batch, observer_estimate_batch
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.linalg import expm
from quad_dob_env.params import VehicleParams
from quad_dob_env.validation import as_finite

PAPER_GAINS = {"translational_gain": 0.02, "rotational_gain": (0.02, 0.2, 0.05)}


def _as_gain_matrix(gain: ArrayLike, name: str) -> NDArray:
    matrix = np.asarray(gain, dtype=float)
    if matrix.ndim == 0 or matrix.shape == (3,):
        matrix = np.diag(np.broadcast_to(matrix, (3,)))
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise ValueError(f"{name} must be a scalar, 3-vector or 3x3 matrix, got {gain!r}")
    if np.any(np.linalg.eigvals(matrix + matrix.T).real <= 0):
        raise ValueError(f"{name} must be positive definite, got {matrix.tolist()}")
    return matrix


class ObserverKernelState(NamedTuple):
    """What the compiled observer equations (``observer_*``) take, for a pass that
    runs them itself: the discrete gains and the per-vehicle state arrays, which it updates
    in place."""

    translational_gain: float  # Ks' = m (1 - e^{-L dt}) / dt
    rotational_gain: NDArray  # Km' (3, 3)
    translational_alpha: float  # 1 - e^{-L dt}
    rotational_alpha: NDArray  # I - e^{-L_Ω dt} (3, 3)
    z_force: NDArray  # (N, 3)
    z_torque: NDArray  # (N, 3)
    fresh: NDArray  # (N,) bool: the vehicle's next estimate starts its episode at zero


class NonlinearDisturbanceObserver:
    """Estimates d_x (world, N) and d_Ω (body, N m) for a batch of vehicles.

    ``translational_gain`` is Ks (scalar); ``rotational_gain`` is Km (scalar, diagonal
    3-vector or 3x3 matrix). ``from_rates`` sets them from desired decay rates.
    """

    def __init__(self, translational_gain: float = 0.02,
                 rotational_gain: ArrayLike = (0.02, 0.2, 0.05)) -> None:
        self.translational_gain = as_finite(translational_gain, "translational_gain (Ks)", 0.0,
                                            strictly=True)
        self.rotational_gain = _as_gain_matrix(rotational_gain, "rotational_gain (Km)")
        self.force_estimate = np.zeros((0, 3))
        self.torque_estimate = np.zeros((0, 3))
        self.inner_period: float | None = None
        self.inner_gains: tuple[NDArray, NDArray] | None = None

    @classmethod
    def from_rates(cls, translational_rate: float, rotational_rate: ArrayLike,
                   vehicle: VehicleParams) -> NonlinearDisturbanceObserver:
        """Gains giving error decay rates ``L`` [1/s]: ``Ks = L m``, ``Km = diag(L_Ω) J``."""
        rate = as_finite(translational_rate, "translational_rate", 0.0, strictly=True)
        rotational = np.broadcast_to(np.asarray(rotational_rate, dtype=float), (3,))
        if not np.all(np.isfinite(rotational)) or np.any(rotational <= 0):
            raise ValueError(f"rotational_rate must be > 0, got {rotational_rate!r}")
        return cls(rate * vehicle.mass, np.diag(rotational) @ vehicle.inertia_matrix)

    def decay_rates(self, vehicle: VehicleParams) -> tuple[float, NDArray]:
        """``Ks/m`` and the eigenvalues of ``Km J⁻¹`` [1/s]."""
        rotational = np.sort(np.linalg.eigvals(self.rotational_gain @ vehicle.inertia_inverse).real)
        return self.translational_gain / vehicle.mass, rotational

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None) -> None:
        if indices is None:
            self.vehicle, self.dt = vehicle, float(dt)
            rate = self.translational_gain / vehicle.mass
            self._alpha = 1.0 - np.exp(-rate * dt)
            self._ks = self._alpha * vehicle.mass / dt
            alpha_rotation = np.eye(3) - expm(
                -self.rotational_gain @ vehicle.inertia_inverse * dt)
            self._alpha_rotation = alpha_rotation
            self._km = alpha_rotation @ vehicle.inertia_matrix / dt
            self._z_force = np.zeros((num_vehicles, 3))
            self._z_torque = np.zeros((num_vehicles, 3))
            self.force_estimate = np.zeros((num_vehicles, 3))
            self.torque_estimate = np.zeros((num_vehicles, 3))
            self._fresh = np.ones(num_vehicles, dtype=bool)
            self._pending = None
            self.set_inner_period(self.inner_period)
        else:
            self._fresh[indices] = True

    def set_inner_period(self, period: float | None) -> None:
        """Run the rotational part at an inner loop's period [s] (None: at the control
        rate): its discrete gains ``inner_gains`` are for that period, the control-rate
        ``estimate`` reads zΩ with them and ``update`` leaves zΩ to the inner loop, which
        advances it each tick (``quad_dob_baselines.inner``)."""
        self.inner_period = period
        if period is None or not hasattr(self, "_km"):
            self.inner_gains = None
            return
        alpha = np.eye(3) - expm(-self.rotational_gain @ self.vehicle.inertia_inverse * period)
        self.inner_gains = (np.ascontiguousarray(alpha @ self.vehicle.inertia_matrix / period),
                            np.ascontiguousarray(alpha))

    def describe(self) -> dict[str, Any]:
        """The gains, as a controller's ``describe`` lists them."""
        return {"Ks": self.translational_gain, "Km": self.rotational_gain.tolist()}

    @property
    def torque_state(self) -> tuple[NDArray, NDArray]:
        """zΩ (N, 3) and the fresh flags (N,), the arrays themselves."""
        return self._z_torque, self._fresh

    def kernel_state(self) -> ObserverKernelState:
        """The discrete gains and state arrays of the last ``reset`` (the arrays themselves,
        not copies: a compiled pass that advances them replaces ``estimate``/``update``)."""
        return ObserverKernelState(float(self._ks), np.array(self._km, dtype=float),
                                   float(self._alpha), np.array(self._alpha_rotation, dtype=float),
                                   self._z_force, self._z_torque, self._fresh)

    def estimate(self, state: VehicleState) -> tuple[NDArray, NDArray]:
        """``d̂x = zx + Ks' v``, ``d̂Ω = zΩ + Km' Ω`` for the current state, after finishing the
        update of the step that led here (it needs this step's end state)."""
        vehicle = self.vehicle
        if self._pending is not None:
            observer_advance_batch(*self._pending, state.rotation, state.angular_velocity,
                                   vehicle.mass, vehicle.gravity, vehicle.inertia_matrix,
                                   self._ks, self._alpha, self._km, self._alpha_rotation,
                                   self._z_force, self._z_torque, self.inner_gains is None)
            self._pending = None
        n = len(state.velocity)
        self.force_estimate, self.torque_estimate = np.empty((n, 3)), np.empty((n, 3))
        km = self._km if self.inner_gains is None else self.inner_gains[0]
        observer_estimate_batch(state.velocity, state.angular_velocity, self._ks, km,
                                self._z_force, self._z_torque, self._fresh,
                                self.force_estimate, self.torque_estimate)
        return self.force_estimate, self.torque_estimate

    def update(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        """Record one control step flown from ``state`` with the applied thrust and moment;
        z advances at the next ``estimate``, when the step's end state is known."""
        self._pending = (state.velocity.copy(), state.rotation[:, :, 2].copy(),
                         state.angular_velocity.copy(),
                         np.ascontiguousarray(thrust, dtype=float).copy(),
                         np.ascontiguousarray(moment, dtype=float).copy())


class GivenDisturbance:
    """An observer that estimates nothing: it hands the controller the force d_x (world, N)
    and torque d_Ω (body, N m) that ``source()`` returns, at each ``estimate``. A controller
    fed the true disturbance this way flies the truth-fed row, the loop's floor where it is
    one (``quad_dob_composition.oracle`` supplies the source from the simulator's truth).
    The torque is held over an inner loop's ticks, as INDI's and L1's estimates are."""

    def __init__(self) -> None:
        self.source: Callable[[], tuple[NDArray, NDArray]] | None = None
        self.force_estimate = np.zeros((0, 3))
        self.torque_estimate = np.zeros((0, 3))
        self.inner_gains: tuple[NDArray, NDArray] | None = None
        self._fresh = np.zeros(0, dtype=bool)

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None) -> None:
        if indices is None:
            self.force_estimate = np.zeros((num_vehicles, 3))
            self.torque_estimate = np.zeros((num_vehicles, 3))
            self._fresh = np.zeros(num_vehicles, dtype=bool)

    def describe(self) -> dict[str, Any]:
        return {"observer": "given: the true disturbance (the loop's floor)"}

    def set_inner_period(self, period: float | None) -> None:
        # zero gains: d̂Ω = zΩ, the given torque, over every tick (``inner.held_torque_estimate``)
        self.inner_gains = None if period is None else (np.zeros((3, 3)), np.zeros((3, 3)))

    @property
    def torque_state(self) -> tuple[NDArray, NDArray]:
        return self.torque_estimate, self._fresh

    def estimate(self, state: VehicleState) -> tuple[NDArray, NDArray]:
        if self.source is None:
            raise RuntimeError("GivenDisturbance has no source: quad_dob_composition binds "
                               "one to the env it flies in (oracle:NAME bases)")
        force, torque = self.source()
        self.force_estimate = np.array(force, dtype=float)
        self.torque_estimate = np.array(torque, dtype=float)
        return self.force_estimate, self.torque_estimate

    def update(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        """Nothing to learn from the step flown."""
