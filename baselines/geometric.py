"""Geometric tracking control on SE(3) (Lee, Leok, McClamroch, CDC 2010), z up, with an
optional nonlinear disturbance observer.

``F = -kx ex - kv ev + m g e3 + m (ẍd + Δa) - d̂x``, ``f = F · R e3``, ``Rd`` from ``F`` and ``b1d``,
``M = -kR eR - kΩ eΩ + Ω × JΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d) - d̂Ω``.

Ωd and Ω̇d come from differentiating Rd analytically: F's first two derivatives use the
trajectory's jerk and snap and the model's prediction of the vehicle's acceleration and
jerk, ``v̇ = -g e3 + (f R e3 + d̂x)/m`` (the estimate d̂x is held constant in them). Δa is
zero unless an outer loop (a residual policy, ``residual_mode="acceleration"``) passes
``acceleration_correction`` to ``compute``; it is held constant in them too.
The equations are written once, per vehicle, in
``quad_dob_baselines.geometric_kernels.geometric_law``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from quad_dob_baselines.base import Controller
from quad_dob_baselines.geometric_kernels import (
    GeometricLaw,
    GeometricOutputs,
    ReferenceVectors,
    geometric_batch,
)
from quad_dob_baselines.inner import LEE, InnerLaw, held_torque_estimate, inner_law
from quad_dob_baselines.observer import NonlinearDisturbanceObserver
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.threads import PARALLEL_MIN_BATCH, run_over_batch
from quad_dob_env.trajectories import Reference
from quad_dob_env.validation import as_finite

# The paper's (and Lee 2010's) gains; kx and kv scale with the vehicle's mass.
PAPER_GAINS = {"kx_per_mass": 16.0, "kv_per_mass": 5.6, "kR": 8.81, "kOmega": 2.54}


class GeometricController(Controller):
    """Lee 2010 geometric tracking controller; with ``observer`` it is geometric + NDOB.

    Gains: ``kx = kx_per_mass m``, ``kv = kv_per_mass m`` (paper: 16 m, 5.6 m), ``kR``,
    ``kOmega`` (paper: 8.81, 2.54); each may be a scalar or a per-axis 3-vector.
    """

    name = "geometric"

    def __init__(self, kx_per_mass: ArrayLike = 16.0, kv_per_mass: ArrayLike = 5.6,
                 kR: ArrayLike = 8.81, kOmega: ArrayLike = 2.54,
                 observer: NonlinearDisturbanceObserver | None = None) -> None:
        super().__init__()
        self.gains = {}
        for key, value in (("kx_per_mass", kx_per_mass), ("kv_per_mass", kv_per_mass),
                           ("kR", kR), ("kOmega", kOmega)):
            gain = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
            for component in gain:
                as_finite(component, f"GeometricController.{key}", 0.0, strictly=True)
            self.gains[key] = gain
        self.observer = observer
        if observer is not None:
            self.name = "geometric-ndob"

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if indices is None:
            self._kx = self.gains["kx_per_mass"] * vehicle.mass
            self._kv = self.gains["kv_per_mass"] * vehicle.mass
            # the law's constants in the kernel's form, once per vehicle model
            self._geometric_law = GeometricLaw(
                mass=vehicle.mass, gravity=vehicle.gravity,
                inertia=tuple(vehicle.inertia_matrix.ravel().tolist()),
                kx=tuple(self._kx.tolist()), kv=tuple(self._kv.tolist()),
                k_attitude=tuple(self.gains["kR"].tolist()),
                k_rate=tuple(self.gains["kOmega"].tolist()))
        if self.observer is not None:
            self.observer.reset(num_vehicles, vehicle, dt, indices)

    @property
    def position_gains(self) -> tuple[NDArray, NDArray]:
        """kx and kv [N/m, N s/m] for the vehicle of the last ``reset`` (per-mass gains times
        its mass)."""
        return self._kx, self._kv

    accepts_acceleration_correction = True

    def compute(self, time: NDArray, state: VehicleState, reference: Reference,
                acceleration_correction: NDArray | None = None) -> tuple[NDArray, NDArray]:
        """One compiled call for the batch (``geometric_law`` per vehicle);
        ``acceleration_correction`` (N, 3) [m/s²], an outer loop's Δa added to ẍd in F."""
        n = len(state.position)
        correction = (np.zeros((n, 3)) if acceleration_correction is None
                      else np.ascontiguousarray(acceleration_correction, dtype=float))
        force_estimate, torque_estimate = self._estimates(state)
        thrust, moment = np.empty(n), np.empty((n, 3))
        self.diagnostics = {
            "desired_force": np.empty((n, 3)),
            "desired_rotation": np.empty((n, 3, 3)),
            "desired_angular_velocity": np.empty((n, 3)),
            "desired_angular_acceleration": np.empty((n, 3)),
            "attitude_error": np.empty((n, 3)),
            "rate_error": np.empty((n, 3)),
            "force_estimate": force_estimate,
            "torque_estimate": torque_estimate,
        }
        references = ReferenceVectors(**{name: np.asarray(getattr(reference, name), dtype=float)
                                         for name in ReferenceVectors._fields})
        d = self.diagnostics
        outputs = GeometricOutputs(
            thrust=thrust, moment=moment, desired_force=d["desired_force"],
            desired_rotation=d["desired_rotation"], desired_rate=d["desired_angular_velocity"],
            desired_acceleration=d["desired_angular_acceleration"],
            attitude_error=d["attitude_error"], rate_error=d["rate_error"])
        # plain tuples across the boundary: numba types a named tuple on a slower path
        run_over_batch(geometric_batch, n, state.position, state.velocity, state.rotation,
                       state.angular_velocity, tuple(references), tuple(self._geometric_law),
                       force_estimate,
                       torque_estimate, correction, tuple(outputs),
                       min_batch=4 * PARALLEL_MIN_BATCH)  # ~1/4 of a physics step's work
        return thrust, moment

    def _estimates(self, state: VehicleState) -> tuple[NDArray, NDArray]:
        """The force and torque ``compute`` subtracts: the observer's, or none."""
        if self.observer is not None:
            return self.observer.estimate(state)
        n = len(state.position)
        return np.zeros((n, 3)), np.zeros((n, 3))

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        if self.observer is not None:
            self.observer.update(state, thrust, moment)

    has_inner_law = True

    def use_inner_loop(self, period: float | None) -> None:
        super().use_inner_loop(period)
        if self.observer is not None:
            self.observer.set_inner_period(period)

    def inner_law(self) -> InnerLaw:
        """Lee's attitude law (kR, kΩ) with the rotational observer at the inner rate."""
        return inner_law(LEE, np.stack([self.gains["kR"], self.gains["kOmega"]]),
                         self.vehicle.inertia_matrix, self.diagnostics,
                         len(self.diagnostics["desired_force"]), self._inner_observer())

    def _inner_observer(self) -> tuple | None:
        """What ``inner_law`` gets as its ``observer``: the rotational observer's gains at
        the inner rate and zΩ, or None."""
        if self.observer is None:
            return None
        km, alpha = self.observer.inner_gains
        return km, alpha, self.observer.torque_state[0]

    def describe(self) -> dict[str, Any]:
        info: dict[str, Any] = {"name": self.name,
                                **{k: v.tolist() for k, v in self.gains.items()}}
        if self.observer is not None:
            info.update(self.observer.describe())
        return info


class EstimatingGeometricController(GeometricController):
    """Lee's law with disturbance estimates a subclass forms once per control step in
    ``_advance(rows)`` (INDI's measured ones, L1's adaptive ones), into ``_force`` and
    ``_torque`` (N, 3); ``force_estimate`` and ``torque_estimate`` are copies of them for
    callers, and an inner loop holds the torque estimate over the step's ticks.

    A vehicle's estimate advances once per flown step: at the first ``compute`` after an
    ``applied`` (or after its reset), so computing again before the next step (a residual
    env's restart of other vehicles, its guarded second command) returns the estimate it
    holds. ``applied`` keeps the step's applied thrust and moment in ``_wrench`` (N, 4)."""

    def __init__(self, own: tuple[str, ...] = (), **gains: ArrayLike) -> None:
        unknown = sorted(set(gains) - set(PAPER_GAINS))
        if unknown:
            raise ValueError(f"unknown {self.name} gain {unknown[0]!r}; valid: "
                             + ", ".join([*PAPER_GAINS, *own]))
        super().__init__(**gains)

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if indices is None:
            n = int(num_vehicles)
            self._wrench = np.zeros((n, 4))
            self._force, self._torque = np.zeros((n, 3)), np.zeros((n, 3))
            self.force_estimate, self.torque_estimate = np.zeros((n, 3)), np.zeros((n, 3))
            self._fresh = np.ones(n, dtype=np.bool_)
            self._stepped = np.zeros(n, dtype=np.bool_)
        else:
            self._fresh[indices] = True
            self._wrench[indices] = 0.0  # nothing applied yet in the new episode

    def _estimates(self, state: VehicleState) -> tuple[NDArray, NDArray]:
        rows = self._fresh | self._stepped
        if rows.any():
            self._advance(state, rows)
        self._stepped[:] = False
        # new arrays each step, as the observer's: a caller may keep the last ones
        self.force_estimate, self.torque_estimate = self._force.copy(), self._torque.copy()
        return self.force_estimate, self.torque_estimate

    def _advance(self, state: VehicleState, rows: NDArray[np.bool_]) -> None:
        """Advance the estimates of the vehicles ``rows`` marks by one step."""
        raise NotImplementedError

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        self._wrench[:, 0] = thrust
        self._wrench[:, 1:] = moment
        self._stepped[:] = True

    def _inner_observer(self) -> tuple:
        return held_torque_estimate(self.torque_estimate)


# Integral action's hand-set start (part 3 tunes it): ki = 8 m [N/(m s)], inside Routh's
# bound kv kx / m² = 89.6 /s³ for the paper's kx, kv; the integral's force at most 0.3 mg.
INTEGRAL_GAINS = {"ki_per_mass": 8.0, "integral_limit_per_weight": 0.3}


class GeometricIntegralController(GeometricController):
    """Lee 2010 with integral action on the position error, in place of an observer:
    ``F = -kx ex - kv ev - ki ∫ex dt + m g e3 + m ẍd``, the integral advanced by forward
    Euler at the control rate and clamped so that ``ki |∫ex|`` stays within
    ``integral_limit_per_weight · m g`` per axis (anti-windup). The counterpart of
    Neural-Fly's "nonlinear baseline with integral action". The integral's force enters the
    geometric law where an observer's estimate would (``force_estimate``), so the law is
    the one ``geometric_law`` writes."""

    name = "geometric-integral"

    def __init__(self, ki_per_mass: float = INTEGRAL_GAINS["ki_per_mass"],
                 integral_limit_per_weight: float = INTEGRAL_GAINS["integral_limit_per_weight"],
                 **gains: ArrayLike) -> None:
        super().__init__(**gains)
        self.name = "geometric-integral"
        self.ki_per_mass = as_finite(ki_per_mass, "GeometricIntegralController.ki_per_mass",
                                     0.0, strictly=True)
        self.integral_limit_per_weight = as_finite(
            integral_limit_per_weight, "GeometricIntegralController.integral_limit_per_weight",
            0.0, strictly=True)
        self.integral = np.zeros((0, 3))

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if indices is None:
            self.integral = np.zeros((num_vehicles, 3))
            self._due = np.ones(num_vehicles, dtype=bool)
        else:
            self.integral[indices] = 0.0
            self._due[indices] = True

    def compute(self, time: NDArray, state: VehicleState, reference: Reference,
                acceleration_correction: NDArray | None = None) -> tuple[NDArray, NDArray]:
        vehicle = self.vehicle
        ki = self.ki_per_mass * vehicle.mass
        limit = self.integral_limit_per_weight * vehicle.hover_thrust / ki
        # ∫ex dt by forward Euler, clamped: ki |∫ex| <= limit_per_weight m g; once per
        # flown step (a second compute before the next step integrates nothing)
        step = self.integrated_error(state, reference) * self.dt
        self.integral = np.clip(self.integral + self._due[:, None] * step, -limit, limit)
        self._due[:] = False
        self._integral_force = ki * self.integral
        return super().compute(time, state, reference, acceleration_correction)

    def integrated_error(self, state: VehicleState, reference: Reference) -> NDArray:
        """What the integral accumulates: the position error ex (a subclass's own law may
        integrate another error)."""
        return state.position - reference.position

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        self._due[:] = True

    def _estimates(self, state: VehicleState) -> tuple[NDArray, NDArray]:
        return self._integral_force, np.zeros_like(self._integral_force)

    def describe(self) -> dict[str, Any]:
        return {**super().describe(), "ki_per_mass": self.ki_per_mass,
                "integral_limit_per_weight": self.integral_limit_per_weight}

