"""Incremental nonlinear dynamic inversion (INDI) on the geometric controller: acceleration
feedback in both loops (Tal & Karaman, IEEE TCST 2021, DOI 10.1109/TCST.2020.3001117;
Smeur, de Croon & Chu, JGCD 2016 and CEP 2018; docs/research/issue-27-indi.md).

INDI commands an increment on what the vehicle is measured to do. Outer loop, Tal &
Karaman eq. (20) in force units: ``F = F_f + m (a_c - a_f)``, the filtered thrust vector
``F_f`` (from the rotor-speed telemetry) corrected by the gap between the commanded
acceleration ``a_c`` and the filtered measured one ``a_f`` (the accelerometer's specific
force rotated to the world frame, less gravity). Inner loop, eq. (31):
``M = M_f + J (α_c - α_f)``, the filtered moment of the rotors plus the inertia times the
gap between the commanded and the filtered measured angular acceleration (the gyroscope
differenced over the step).

Written with the geometric law's ``a_c = ẍd - (kx ex + kv ev) / m`` and
``α_c = J⁻¹(-kR eR - kΩ eΩ - J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d))``, these are Lee's law with the
disturbances INDI measures (Tal & Karaman eqs. 18 and 29) in the place of an observer's:

``d̂x = LPF(m R a_b - f_tel R e3)``, ``d̂Ω = LPF(J ΔΩ/dt + Ω̄ × JΩ̄ - M_tel)``,

``a_b`` the accelerometer [m/s²], ``f_tel, M_tel`` the collective thrust and moment of the
rotor speeds the ESCs report (``k_F ω²`` through the allocation matrix), ``ΔΩ`` the
gyroscope's change over the step and ``Ω̄`` its mean. One filter runs on the difference,
so the acceleration and the actuator state it is compared with share one phase lag, the
condition Tal & Karaman (citing Smeur 2016) put on INDI. The filter is a second-order
Butterworth at ``filter_bandwidth`` [rad/s] (``quad_dob_baselines.filters``).

Without telemetry (``actuator_state="model"``; Neural-Fly's vehicle had PWM only,
docs/research/issue-27-indi.md) the rotors' state is a first-order model of the wrench the
autopilot commanded, at a motor time constant τ (``actuator_time_constant``; None: the
vehicle's nominal), as Paparazzi's INDI does without RPM feedback with its identified
``act_dyn`` ([PPZ-S] there): ``u_f ← u_f + (1 − e^{−dt/τ})
(u_c − u_f)``, ``u_c`` the wrench ``applied`` was told over the step (a loop's
``estimator_wrench="commanded"`` tells it the command), ``u_f`` starting at hover.
``"telemetry"`` (v1-v3) reads the rotor speeds.

``loops="outer"`` closes the outer loop alone: the attitude is Lee's law with no torque
estimate, as a position loop over an autopilot's own attitude controller flies.
``filter_order=1`` runs a first-order low-pass ``y ← y + (1 − e^{−ω dt})(x − y)`` in the
Butterworth's place. The name ``indi-outer`` is both, at 5 Hz: the INDI Neural-Fly flew
(``NEURAL_FLY_INDI``).

Timing: the telemetry is each rotor's speed over the last step and the gyroscope's
difference spans the same step, so the two describe one interval. Both readings come once
per control step (that is how this simulator draws them), so the increments are formed at
the control rate and the attitude law of an inner loop holds d̂Ω over the step's ticks.
With the paper's wrench actuation (``actuation="wrench"``, v1's paper-* scenarios) there
are no rotors to report: the applied wrench stands in for the telemetry. Under
``benchmark="v1"`` the readings are ideal (the true specific force, gyroscope and rotor
speeds), so INDI there measures the disturbance exactly, one step late, through its filter.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from quad_dob_baselines.filters import (
    NEURAL_FLY_FILTER_BANDWIDTH,
    butterworth_lowpass,
    butterworth_settle,
    butterworth_step,
    first_order_lowpass,
)
from quad_dob_baselines.geometric import EstimatingGeometricController
from quad_dob_baselines.geometric_kernels import matrix_at, vector_at
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.so3 import cross_tuple, mat_vec_tuple, matrix_entries
from quad_dob_env.validation import as_finite

# Smeur et al. 2018's second-order filter, ω_n = 50 rad/s (8 Hz, the cutoff Paparazzi's
# and the Crazyflie's INDI ports use): v1's setting; v2's is tuned (gain_sets).
INDI_FILTER = {"filter_bandwidth": 50.0}
# where INDI reads the rotors' state: their speeds' telemetry (v1-v3), or a first-order
# model of the commanded wrench (a vehicle without telemetry: module docstring)
ACTUATOR_STATES = ("telemetry", "model")
# the loops INDI closes: both (Tal & Karaman §III-A and B), or the outer alone, its attitude
# Lee's law with no torque estimate (a position loop over an autopilot's attitude loop)
INDI_LOOPS = ("both", "outer")
# the estimate's low-pass: 1, first order; 2, the second-order Butterworth
FILTER_ORDERS = (1, 2)
# The INDI Neural-Fly flew (O'Connell et al., Sci. Robot. 2022, supplement §S6; docs/research/
# issue-27-indi.md, [NF]): Tal & Karaman's outer loop alone, its 50 Hz position loop over
# PX4's attitude controller, and their first-order 5 Hz filter. The name indi-outer.
NEURAL_FLY_INDI = {"loops": "outer", "filter_order": 1,
                   "filter_bandwidth": NEURAL_FLY_FILTER_BANDWIDTH}


class IndiFilter(NamedTuple):
    """The low-pass every INDI residual passes, one channel per residual (3 force, 3
    torque) and vehicle."""

    section: NDArray  # (b0, b1, b2, a1, a2) of the Butterworth section (filter_order 2)
    inputs: NDArray  # (N, 2, 6) the last two inputs, newest first
    outputs: NDArray  # (N, 2, 6) the last two outputs, newest first (first order: [:, 0])
    first_order: float  # the share of the gap closed a step, 1 - e^{-ω dt}; 0: Butterworth


@njit(cache=True, inline="always")
def _filter_step(low_pass, value, i, k):
    section, inputs, outputs, first_order = low_pass
    if first_order > 0.0:
        outputs[i, 0, k] += first_order * (value - outputs[i, 0, k])
        return outputs[i, 0, k]
    return butterworth_step(section, value, inputs, outputs, i, k)


class ActuatorModel(NamedTuple):
    """INDI's first-order model of its actuators, without telemetry."""

    modelled: NDArray  # (N, 4) the modelled wrench: thrust, moment
    rate: float  # the share of the gap to the told wrench closed a step, 1 - e^{-dt/τ}; 0: off
    hover_thrust: float  # [N] where it starts: nothing commanded yet, the rotors at hover


@njit(cache=True)
def indi_measured_disturbances(rows, rotation, gyroscope, accelerometer, rotor_speeds, wrench,
                               from_rotors, mass, inertia, thrust_coefficient, allocation, dt,
                               low_pass, previous_gyro, fresh, force_estimate, torque_estimate,
                               model, torque_loop):
    """d̂x, d̂Ω (module docstring) for the vehicles ``rows`` marks after one control step;
    a ``fresh`` vehicle starts its filters settled on its first force residual and a zero
    torque one (no earlier gyroscope reading to difference). ``model`` (an
    ``ActuatorModel`` as a plain tuple) with a rate above 0: the actuators' state is its
    first-order model of the told ``wrench``; else the telemetry (``from_rotors``) or the
    told wrench itself. ``low_pass`` is an ``IndiFilter`` as a plain tuple. Without the
    ``torque_loop`` (``loops="outer"``) the torque estimate stays zero and is not formed."""
    J = matrix_entries(inertia)
    inputs, outputs = low_pass[1], low_pass[2]
    modelled, model_rate, hover_thrust = ActuatorModel(*model)
    for i in range(rotation.shape[0]):
        if not rows[i]:
            continue
        R = matrix_at(rotation, i)
        if model_rate > 0.0:
            for k in range(4):
                if fresh[i]:  # nothing commanded yet: the rotors at hover
                    modelled[i, k] = hover_thrust if k == 0 else 0.0
                else:
                    modelled[i, k] += model_rate * (wrench[i, k] - modelled[i, k])
            thrust_moment = [modelled[i, k] for k in range(4)]
        elif from_rotors:
            rotor_thrusts = [thrust_coefficient * rotor_speeds[i, k] ** 2 for k in range(4)]
            thrust_moment = [allocation[row, 0] * rotor_thrusts[0]
                             + allocation[row, 1] * rotor_thrusts[1]
                             + allocation[row, 2] * rotor_thrusts[2]
                             + allocation[row, 3] * rotor_thrusts[3] for row in range(4)]
        else:
            thrust_moment = [wrench[i, k] for k in range(4)]
        specific = mat_vec_tuple(R, vector_at(accelerometer, i))
        # m R a_b - f R e3: the world-frame force beyond the rotors' thrust (TK eq. 18)
        force = (mass * specific[0] - thrust_moment[0] * R[2],
                 mass * specific[1] - thrust_moment[0] * R[5],
                 mass * specific[2] - thrust_moment[0] * R[8])
        rate = vector_at(gyroscope, i)
        if fresh[i]:
            for k in range(3):
                butterworth_settle(force[k], inputs, outputs, i, k)
                butterworth_settle(0.0, inputs, outputs, i, 3 + k)
                force_estimate[i, k] = force[k]
                torque_estimate[i, k] = 0.0
                previous_gyro[i, k] = rate[k]
            fresh[i] = False
            continue
        before = vector_at(previous_gyro, i)
        mean_rate = (0.5 * (rate[0] + before[0]), 0.5 * (rate[1] + before[1]),
                     0.5 * (rate[2] + before[2]))
        change = ((rate[0] - before[0]) / dt, (rate[1] - before[1]) / dt,
                  (rate[2] - before[2]) / dt)
        inertial = mat_vec_tuple(J, change)
        gyroscopic = cross_tuple(mean_rate, mat_vec_tuple(J, mean_rate))
        for k in range(3):
            force_estimate[i, k] = _filter_step(low_pass, force[k], i, k)
            if torque_loop:
                # J Ω̇ + Ω × JΩ - M: the body torque beyond the rotors' moment (TK eq. 29)
                torque = inertial[k] + gyroscopic[k] - thrust_moment[1 + k]
                torque_estimate[i, k] = _filter_step(low_pass, torque, i, 3 + k)
            previous_gyro[i, k] = rate[k]


class IncrementalNDI(EstimatingGeometricController):
    """INDI (module docstring): Lee's law with the disturbances it measures from the IMU
    and the rotor-speed telemetry. Gains: the geometric controller's (``kx_per_mass``,
    ``kv_per_mass``, ``kR``, ``kOmega``) and ``filter_bandwidth`` [rad/s]."""

    name = "indi"

    def __init__(self, filter_bandwidth: float = INDI_FILTER["filter_bandwidth"],
                 actuator_state: str = "telemetry", actuator_time_constant: float | None = None,
                 loops: str = "both", filter_order: int = 2, **gains: ArrayLike) -> None:
        super().__init__((*INDI_FILTER, "actuator_state", "actuator_time_constant", "loops",
                          "filter_order"), **gains)
        # held to the control step's Nyquist rate at reset, when the step is known
        self.filter_bandwidth = as_finite(filter_bandwidth, "IncrementalNDI.filter_bandwidth",
                                          0.0, strictly=True)
        if actuator_state not in ACTUATOR_STATES:
            raise ValueError(f"unknown IncrementalNDI.actuator_state {actuator_state!r}; "
                             f"valid: {', '.join(ACTUATOR_STATES)}")
        if loops not in INDI_LOOPS:
            raise ValueError(f"unknown IncrementalNDI.loops {loops!r}; valid: "
                             f"{', '.join(INDI_LOOPS)}")
        if filter_order not in FILTER_ORDERS:
            raise ValueError(f"IncrementalNDI.filter_order must be one of "
                             f"{', '.join(map(str, FILTER_ORDERS))}, got {filter_order!r}")
        self.actuator_state = actuator_state
        self.loops = loops
        self.filter_order = int(filter_order)
        # [s] the model's time constant (None: the vehicle's nominal motor_time_constant)
        self.actuator_time_constant = (None if actuator_time_constant is None else as_finite(
            actuator_time_constant, "IncrementalNDI.actuator_time_constant", 0.0,
            strictly=True))

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        super().reset(num_vehicles, vehicle, dt, indices, actuation)
        if indices is None:
            n = int(num_vehicles)
            section = butterworth_lowpass(self.filter_bandwidth, self.dt,
                                          "IncrementalNDI.filter_bandwidth")
            self._filter = IndiFilter(
                section, np.zeros((n, 2, 6)), np.zeros((n, 2, 6)),
                1.0 - first_order_lowpass(self.filter_bandwidth, self.dt,
                                          "IncrementalNDI.filter_bandwidth")
                if self.filter_order == 1 else 0.0)
            self._previous_gyro = np.zeros((n, 3))
            self._modelled = np.zeros((n, 4))  # the actuators' modelled wrench
            # the model's share of the gap a step, 1 - e^{-dt/τ}; 0: no model
            tau = float(vehicle.motor_time_constant if self.actuator_time_constant is None
                        else self.actuator_time_constant)
            if self.actuator_state == "model" and tau <= 0:
                raise ValueError(f"indi's actuator_state 'model' needs the vehicle's motor time "
                                 f"constant; {vehicle.name!r} has {tau!r} s")
            self._model_rate = (1.0 - np.exp(-self.dt / tau) if self.actuator_state == "model"
                                else 0.0)

    def _advance(self, state: VehicleState, rows: NDArray[np.bool_]) -> None:
        vehicle = self.vehicle
        for name in ("gyroscope", "accelerometer", "rotor_speeds"):
            if getattr(state, name, None) is None:
                raise ValueError(f"indi reads the IMU and the rotor speeds: compute needs a "
                                 f"sensing.Measurement with {name}, got a "
                                 f"{type(state).__name__}")
        indi_measured_disturbances(
            rows, state.rotation, state.gyroscope, state.accelerometer, state.rotor_speeds,
            self._wrench, self.actuation == "rotors", vehicle.mass, vehicle.inertia_matrix,
            vehicle.thrust_coefficient, vehicle.allocation_matrix, self.dt, tuple(self._filter),
            self._previous_gyro, self._fresh, self._force, self._torque,
            (self._modelled, self._model_rate, vehicle.hover_thrust), self.loops == "both")

    def describe(self) -> dict[str, Any]:
        return {**super().describe(), "filter_bandwidth": self.filter_bandwidth,
                "actuator_state": self.actuator_state,
                "actuator_time_constant": self.actuator_time_constant, "loops": self.loops,
                "filter_order": self.filter_order}
