"""The controllers Neural-Fly flew without learned features, as their paper writes them
(O'Connell et al., "Neural-Fly enables rapid learning for agile flight in strong winds",
Science Robotics 7 (2022), arXiv:2205.06908; docs/benchmark-v4.md, part 2): Neural-Fly-
Constant (NF-C, ``NeuralFlyConstant``, below) and their nonlinear baseline with integral
action (``NeuralFlyBaseline``, at the end).

The position law (their eqs. 7 and 10, with M = m I, C = 0 and u the force the thrust
vector gives, eq. 13): ``u = m ẍ_r - K s - f̂ + m g e3``, ``s = ṽ + Λ p̃``,
``ẍ_r = ẍ_d - Λ ṽ``, so ``u = -(K + m Λ) ṽ - K Λ p̃ + m ẍ_d + m g e3 - f̂``: Lee's law with
``kv = K + m Λ``, ``kx = K Λ`` and the adapted force in the estimate's slot. Per mass:
``k_per_mass = K / m`` [1/s] and ``composite_rate = Λ`` [1/s].

The adaptation, NF-C's (their φ = I: the estimate is the force itself, their Corollary 7
with Q = q I, R = r I, P(0) = p0 I), in the discrete form of their supplement §S4
(eqs. 15-19), per control step Δt, each vehicle's covariance a scalar times I:

- propagate: ``â⁻ = (1 - λΔt) â``, ``p⁻ = (1 - λΔt)² p + q Δt``;
- gain: ``k = p⁻ / (p⁻ + r Δt)``, ``r = q / ω_a²`` for the estimate's steady bandwidth
  ``ω_a = √(q/r)`` [1/s] (``adaptation_rate``);
- update: ``â = â⁻ - k (â⁻ - y) + p⁻ s Δt``, ``p = (1 - k)² p⁻ + k² r Δt`` (Joseph form).

The tracking term's sign and Δt are their continuous law's (eq. 8, ``+P φᵀ s``, which their
stability proof needs); the supplement's eq. 18 prints it with a minus and without Δt.
``y`` is the measured residual force, as they compute ``fa``: ``m (v̇ + g e3) - f R e3``,
``v̇`` the estimated velocity's difference over the step and ``f R e3`` the thrust the
vehicle was told it applied over it (its two ends' thrust axes averaged). Their gains K, Λ,
p0 and r are not published (§S6: q of the order of 0.1, λ = 0.01; the same K and Λ for
every method); this benchmark's come from ``quad-dob tune`` (``gain_sets``).

Neural-Fly sent thrust and attitude to PX4's own attitude controller; here the geometric
attitude law flies the attitude, with no torque estimate (none of their controllers
estimated a torque). ``tests/test_neural_fly.py`` holds the update to the equations above,
written out.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from quad_dob_baselines.geometric import (
    EstimatingGeometricController,
    GeometricIntegralController,
)
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.trajectories import Reference
from quad_dob_env.validation import as_finite

# Neural-Fly's own adaptation values where their supplement gives them (§S6: "Q on the
# order of 0.1", λ = 0.01). r, "similar to the measurement noise" and unpublished, is set
# through the estimate's steady bandwidth, √(q/r) (a scalar Kalman filter on a random walk:
# p = √(q r), gain p / r), which ``quad-dob tune`` searches under the cap every estimator
# keeps; p0 its steady value at that bandwidth's start, 1 (their P(0) is unpublished)
NF_CONSTANT_ADAPTATION = {"process_noise": 0.1, "forgetting": 0.01, "initial_covariance": 1.0,
                          "adaptation_rate": 5.0}
# the composite law's gains to start a search from: the paper vehicle's Lee gains (16, 5.6
# per kg) have no real factorization K Λ, K + m Λ (5.6² < 4 x 16); Λ = 2 /s, K = 2.8 m
# give kx = 5.6 and kv = 4.8 per kg
NF_CONSTANT_GAINS = {"k_per_mass": 2.8, "composite_rate": 2.0}


def lee_gains(k_per_mass: float, composite_rate: float) -> dict[str, float]:
    """Lee's position gains per kg of the composite law ``-K s``, ``s = ṽ + Λ p̃``:
    ``kx = K Λ``, ``kv = K + m Λ`` (per kg: ``K/m · Λ`` and ``K/m + Λ``)."""
    return {"kx_per_mass": k_per_mass * composite_rate,
            "kv_per_mass": k_per_mass + composite_rate}


def composite_error(state: VehicleState, reference: Reference, composite_rate: float
                    ) -> NDArray:
    """Their composite error ``s = ṽ + Λ p̃`` (eq. 10), (N, 3)."""
    return (state.velocity - reference.velocity) + composite_rate * (
        state.position - reference.position)


def composite_gains(k_per_mass: float, composite_rate: float, law: str,
                    gains: dict[str, Any], refused: tuple[str, ...]) -> tuple[float, float]:
    """``(K/m, Λ)`` checked, refusing Lee's gains among ``gains`` (``refused``): the
    composite law's are K and Λ."""
    for name in refused:
        if name in gains:
            raise ValueError(f"{law}'s position gains are k_per_mass and composite_rate "
                             f"(kx = K Λ, kv = K + m Λ), not {name}")
    return (as_finite(k_per_mass, f"{law}.k_per_mass", 0.0, strictly=True),
            as_finite(composite_rate, f"{law}.composite_rate", 0.0, strictly=True))


class NeuralFlyConstant(EstimatingGeometricController):
    """NF-C (module docstring): the composite law ``-K s`` with the force ``f̂`` adapted by
    NF-C's composite adaptation. Gains: ``k_per_mass`` (K / m) [1/s], ``composite_rate``
    (Λ) [1/s], the attitude law's ``kR`` and ``kOmega``, and the adaptation's
    ``process_noise`` q, ``adaptation_rate`` ω_a [1/s] (the measurement noise r = q / ω_a²),
    ``initial_covariance`` p0 and ``forgetting`` λ."""

    name = "nf-constant"

    def __init__(self, k_per_mass: float = NF_CONSTANT_GAINS["k_per_mass"],
                 composite_rate: float = NF_CONSTANT_GAINS["composite_rate"],
                 process_noise: float = NF_CONSTANT_ADAPTATION["process_noise"],
                 adaptation_rate: float = NF_CONSTANT_ADAPTATION["adaptation_rate"],
                 initial_covariance: float = NF_CONSTANT_ADAPTATION["initial_covariance"],
                 forgetting: float = NF_CONSTANT_ADAPTATION["forgetting"],
                 **gains: ArrayLike) -> None:
        own = ("k_per_mass", "composite_rate", *NF_CONSTANT_ADAPTATION)
        self.k_per_mass, self.composite_rate = composite_gains(
            k_per_mass, composite_rate, "nf-constant", gains, ("kx_per_mass", "kv_per_mass"))
        super().__init__(own, **lee_gains(self.k_per_mass, self.composite_rate), **gains)
        self.name = "nf-constant"
        self.process_noise = as_finite(process_noise, "NeuralFlyConstant.process_noise", 0.0,
                                       strictly=True)
        self.adaptation_rate = as_finite(adaptation_rate, "NeuralFlyConstant.adaptation_rate",
                                         0.0, strictly=True)
        # r from the bandwidth: ω_a = √(q/r)
        self.measurement_noise = self.process_noise / self.adaptation_rate**2
        self.initial_covariance = as_finite(initial_covariance,
                                            "NeuralFlyConstant.initial_covariance", 0.0)
        self.forgetting = as_finite(forgetting, "NeuralFlyConstant.forgetting", 0.0)

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if self.forgetting * self.dt >= 1.0:
            raise ValueError(f"NeuralFlyConstant.forgetting λ = {self.forgetting:g} /s forgets "
                             f"more than all of the estimate in a step of {self.dt:g} s: "
                             f"allowed λ Δt < 1")
        if indices is None:
            n = int(num_vehicles)
            self.adapted = np.zeros((n, 3))  # â [N], the force estimate
            self.covariance = np.full(n, self.initial_covariance)  # p, P = p I
            self._last_velocity, self._last_axis = np.zeros((n, 3)), np.zeros((n, 3))
            self._composite = np.zeros((n, 3))  # s at the step's end
        else:
            self.adapted[indices] = 0.0
            self.covariance[indices] = self.initial_covariance

    def compute(self, time: NDArray, state: VehicleState, reference: Reference,
                acceleration_correction: NDArray | None = None) -> tuple[NDArray, NDArray]:
        # s = ṽ + Λ p̃ now, which the estimate's tracking term reads
        self._composite = composite_error(state, reference, self.composite_rate)
        return super().compute(time, state, reference, acceleration_correction)

    def _advance(self, state: VehicleState, rows: NDArray[np.bool_]) -> None:
        fresh = self._fresh & rows
        stepped = rows & ~fresh
        axis = state.rotation[:, :, 2]
        if stepped.any():
            self._update(state, axis, stepped)
        # a fresh vehicle has no step to difference: it starts where it is
        self._last_velocity[rows] = state.velocity[rows]
        self._last_axis[rows] = axis[rows]
        self._fresh[rows] = False
        self._force = self.adapted.copy()

    def _update(self, state: VehicleState, axis: NDArray, rows: NDArray[np.bool_]) -> None:
        """One step of NF-C's adaptation for the vehicles ``rows`` marks."""
        m, g, dt = self.vehicle.mass, self.vehicle.gravity, self.dt
        # y = m (v̇ + g e3) - f R e3: the residual force over the step, the thrust the
        # vehicle was told along the mean of the step's two thrust axes
        acceleration = (state.velocity[rows] - self._last_velocity[rows]) / dt
        acceleration[:, 2] += g
        thrust_axis = 0.5 * (axis[rows] + self._last_axis[rows])
        measured = m * acceleration - self._wrench[rows, :1] * thrust_axis
        decay = 1.0 - self.forgetting * dt
        estimate = decay * self.adapted[rows]
        covariance = decay**2 * self.covariance[rows] + self.process_noise * dt
        gain = covariance / (covariance + self.measurement_noise * dt)
        self.adapted[rows] = (estimate - gain[:, None] * (estimate - measured)
                              + (covariance * dt)[:, None] * self._composite[rows])
        self.covariance[rows] = ((1.0 - gain) ** 2 * covariance
                                 + gain**2 * self.measurement_noise * dt)

    def describe(self) -> dict[str, Any]:
        return {**super().describe(), "k_per_mass": self.k_per_mass,
                "composite_rate": self.composite_rate, "process_noise": self.process_noise,
                "adaptation_rate": self.adaptation_rate,
                "initial_covariance": self.initial_covariance, "forgetting": self.forgetting}


# The baseline's integral limit, which Neural-Fly do not give: from physics, enough force
# per axis to hold Benchmark v4's mean drag at the tunnel's 12.1 m/s, 14.6 N (0.59 of the
# neural-fly vehicle's weight; quad_dob_env.benchmark_v4's fitted drag, docs/benchmark-v4.md),
# with a margin of a quarter: the figure-8's own airspeed swing (12.1 ± 1.25 m/s, a drag of
# V^1.44 15 % above the mean at the swing's top) and the tunnel's gusts (4 % turbulence: two
# σ of airspeed, 12 % more drag) on top of the mean. 0.59 x 1.25 = 0.74, rounded up.
NF_BASELINE_INTEGRAL = {"composite_ki_per_mass": 1.0, "integral_limit_per_weight": 0.75}


class NeuralFlyBaseline(GeometricIntegralController):
    """Neural-Fly's nonlinear baseline (their eq. 11): the composite law with integral
    action on the composite error, ``u = m ẍ_r - K s - K_I ∫ s dt + m g e3``, ``s = ṽ + Λ
    p̃``: Lee's law with ``kx = K Λ``, ``kv = K + m Λ`` and the integral's force in the
    estimate's slot. ``∫ s dt`` is advanced by forward Euler once per flown step and clamped
    so that ``K_I |∫ s dt|`` stays within ``integral_limit_per_weight · m g`` per axis
    (``NF_BASELINE_INTEGRAL``: the limit from physics, none being published). Gains:
    ``k_per_mass`` (K / m), ``composite_rate`` (Λ), ``composite_ki_per_mass`` (K_I / m)
    [1/s²: ∫ s dt is in metres, where ``geometric-integral``'s ∫ ex dt is in metre-seconds],
    the limit, and the attitude law's ``kR``, ``kOmega``. Their supplement's Fig. S3 caption
    writes the integral on p̃; their eq. 11, the law, on s: this is eq. 11."""

    name = "nf-baseline"

    def __init__(self, k_per_mass: float = NF_CONSTANT_GAINS["k_per_mass"],
                 composite_rate: float = NF_CONSTANT_GAINS["composite_rate"],
                 composite_ki_per_mass: float = NF_BASELINE_INTEGRAL["composite_ki_per_mass"],
                 integral_limit_per_weight: float = NF_BASELINE_INTEGRAL[
                     "integral_limit_per_weight"],
                 **gains: ArrayLike) -> None:
        # its integral gain is composite_ki_per_mass (its own units), not ki_per_mass
        self.k_per_mass, self.composite_rate = composite_gains(
            k_per_mass, composite_rate, "nf-baseline", gains,
            ("kx_per_mass", "kv_per_mass", "ki_per_mass"))
        super().__init__(ki_per_mass=composite_ki_per_mass,
                         integral_limit_per_weight=integral_limit_per_weight,
                         **lee_gains(self.k_per_mass, self.composite_rate), **gains)
        self.name = "nf-baseline"

    def integrated_error(self, state: VehicleState, reference: Reference) -> NDArray:
        """What the integral accumulates: the composite error s = ṽ + Λ p̃."""
        return composite_error(state, reference, self.composite_rate)

    def describe(self) -> dict[str, Any]:
        described = super().describe()
        described["composite_ki_per_mass"] = described.pop("ki_per_mass")
        return {**described, "k_per_mass": self.k_per_mass,
                "composite_rate": self.composite_rate}
