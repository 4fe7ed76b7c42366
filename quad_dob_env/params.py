"""Vehicle parameters: a validated, frozen dataclass and the named presets.

Rotor geometry fixes the allocation matrix that maps the four rotor thrusts to the
collective thrust and body moments, ``[f, Mx, My, Mz] = A @ rotor_thrusts``: a rotor at
body position ``(px, py)`` pushing ``t`` along body +z adds ``py t`` to ``Mx``, ``-px t``
to ``My``, and its drag torque ``spin * c * t`` to ``Mz``.

Every number of every preset has its source in ``VEHICLE_SOURCES`` (docs/physics.md tabulates
it): the paper and Lee et al. 2010 for the paper vehicle's mass, inertia and arm; the UIUC
propeller data of its 10-inch propeller class for its yaw moment per newton of thrust; our
stated estimates for what the paper does not give (rotor limit, drag, motor lag).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.validation import unknown_name_error

# where every number of each preset comes from (a test holds every field to a source)
from quad_dob_env.vehicle_sources import VEHICLE_SOURCES as VEHICLE_SOURCES

Actuation = Literal["rotors", "wrench"]
ACTUATIONS: tuple[str, ...] = ("rotors", "wrench")
CONFIGURATIONS: tuple[str, ...] = ("plus", "x", "wide-x")


def _require_positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ValueError(f"VehicleParams.{name} must be a finite number > 0, got {value!r}")


@dataclass(frozen=True)
class VehicleParams:
    """Rigid-body and rotor parameters of one quadrotor (SI units, z up).

    ``inertia`` is the 3x3 body-frame inertia matrix as nested tuples, so the dataclass
    stays hashable; ``inertia_matrix`` gives it as an array.
    """

    name: str
    mass: float
    inertia: tuple[tuple[float, float, float], ...]
    arm_length: float
    torque_coefficient: float  # yaw drag torque per newton of rotor thrust [m]
    max_rotor_thrust: float  # [N], each rotor is clipped to [0, max_rotor_thrust]
    rotor_radius: float  # [m], sets the ground effect's reach
    configuration: str = "plus"
    # "wide-x" only: the rotors sit at (±arm_length, ±arm_width) [m], front-back and sideways
    # half spacings (an X stretched sideways); the other configurations ignore it
    arm_width: float = 0.0
    gravity: float = 9.81
    # Body-frame aerodynamic drag on the air-relative velocity u = Rᵀ(v - w):
    # F_body = -(drag_linear ⊙ u + drag_quadratic ⊙ |u| ⊙ u); used where a scenario has drag.
    drag_linear: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [N/(m/s)]
    drag_quadratic: tuple[float, float, float] = (0.0, 0.0, 0.0)  # [N/(m/s)²]
    # First-order lag of each rotor's thrust, or with speed motors of its speed; used where a
    # scenario turns motor lag on.
    motor_time_constant: float = 0.0  # [s]
    # Rotor thrust per squared rotor speed, T = k_F ω² [N/(rad/s)²]: what rotor-speed
    # telemetry reports (quad_dob_env.sensing).
    thrust_coefficient: float = 1.4916e-5
    # Largest body rate the vehicle measures: the gyroscope's full-scale range.
    max_body_rate: float = math.radians(2000.0)  # [rad/s]
    # Rotor aerodynamics (quad_dob_env.dynamics.rotors, where a scenario turns them on):
    # rotor drag D = -k_d ω u_inplane per rotor, thrust T = k_F ω² (1 + a_μ μ² + a_λ λ²)
    # - k_z ω u_axial (μ, λ: in-plane and axial airspeed over the tip speed ωR), and the
    # rotor hubs' height above the centre of mass, where the drag acts.
    rotor_drag_coefficient: float = 0.0  # k_d [N/(rad/s · m/s)]
    inflow_coefficient: float = 0.0  # k_z [N/(rad/s · m/s)]
    inflow_quadratic: tuple[float, float] = (0.0, 0.0)  # (a_μ, a_λ), dimensionless
    rotor_height: float = 0.0  # [m]
    _matrices: dict = field(default=None, init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        for name in ("mass", "arm_length", "torque_coefficient", "max_rotor_thrust",
                     "thrust_coefficient",
                     "rotor_radius", "gravity", "max_body_rate"):
            _require_positive(name, getattr(self, name))
        for name in ("drag_linear", "drag_quadratic"):
            values = np.asarray(getattr(self, name), dtype=float)
            if values.shape != (3,) or not np.all(np.isfinite(values)) or np.any(values < 0):
                raise ValueError(f"VehicleParams.{name} must be three finite numbers >= 0, "
                                 f"got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(float(v) for v in values))
        quadratic = np.asarray(self.inflow_quadratic, dtype=float)
        if quadratic.shape != (2,) or not np.all(np.isfinite(quadratic)):
            raise ValueError(f"VehicleParams.inflow_quadratic must be two finite numbers "
                             f"(a_μ, a_λ), got {self.inflow_quadratic!r}")
        object.__setattr__(self, "inflow_quadratic", tuple(float(v) for v in quadratic))
        for name in ("motor_time_constant", "rotor_drag_coefficient", "inflow_coefficient"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"VehicleParams.{name} must be a finite number >= 0, "
                                 f"got {value!r}")
        if not (isinstance(self.rotor_height, (int, float)) and math.isfinite(self.rotor_height)):
            raise ValueError(f"VehicleParams.rotor_height must be a finite number, got "
                             f"{self.rotor_height!r}")
        if self.configuration not in CONFIGURATIONS:
            raise unknown_name_error("rotor configuration", self.configuration, CONFIGURATIONS)
        if self.configuration == "wide-x":
            _require_positive("arm_width", self.arm_width)
        inertia = np.asarray(self.inertia, dtype=float)
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)):
            raise ValueError(
                f"VehicleParams.inertia must be a finite 3x3 matrix, got {self.inertia!r}")
        if not np.allclose(inertia, inertia.T, rtol=0, atol=1e-12 * np.abs(inertia).max()):
            raise ValueError(f"VehicleParams.inertia must be symmetric, got {inertia.tolist()}")
        principal = np.linalg.eigvalsh(inertia)
        if principal[0] <= 0:
            raise ValueError(
                f"VehicleParams.inertia must be positive definite; eigenvalues {principal.tolist()}"
            )
        # A rigid body's principal moments obey the triangle inequality J1 + J2 >= J3.
        if principal[0] + principal[1] < principal[2] * (1 - 1e-9):
            raise ValueError(
                "VehicleParams.inertia is not a rigid body's: principal moments "
                f"{principal.tolist()} break J1 + J2 >= J3"
            )
        weight = self.mass * self.gravity
        if 4 * self.max_rotor_thrust <= weight:
            raise ValueError(
                f"VehicleParams.max_rotor_thrust = {self.max_rotor_thrust} N cannot lift the "
                f"vehicle: 4 rotors give {4 * self.max_rotor_thrust:.4g} N, its weight is "
                f"{weight:.4g} N"
            )
        object.__setattr__(self, "inertia", tuple(tuple(float(v) for v in row) for row in inertia))
        object.__setattr__(self, "_matrices", self._build_matrices(inertia))

    def _build_matrices(self, inertia: NDArray) -> dict:
        if self.configuration == "plus":
            positions = self.arm_length * np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]])
        elif self.configuration == "x":
            positions = self.arm_length / math.sqrt(2) * np.array(
                [[1.0, -1], [1, 1], [-1, 1], [-1, -1]]
            )
        else:  # wide-x: the X's rotor order, front-back and sideways spacings apart
            positions = np.array([[1.0, -1], [1, 1], [-1, 1], [-1, -1]]) * np.array(
                [self.arm_length, self.arm_width])
        spin = np.array([-1.0, 1, -1, 1])  # opposite rotors turn the same way
        allocation = np.vstack([
            np.ones(4), positions[:, 1], -positions[:, 0], spin * self.torque_coefficient
        ])
        roll_pitch = np.array([
            np.abs(allocation[1]).sum() / 2, np.abs(allocation[2]).sum() / 2
        ]) * self.max_rotor_thrust
        matrices = {
            "inertia": inertia,
            "inertia_inverse": np.linalg.inv(inertia),
            "allocation": allocation,
            "mixer": np.linalg.inv(allocation),
            "moment_limit_rotors": np.array(
                [roll_pitch[0], roll_pitch[1], 2 * self.torque_coefficient * self.max_rotor_thrust]
            ),
            # Wrench actuation idealises the vehicle as the paper's model does: any moment
            # up to the rotors' roll authority, on every axis, yaw included.
            "moment_limit_wrench": np.full(3, roll_pitch.max()),
        }
        for matrix in matrices.values():
            matrix.setflags(write=False)
        return matrices

    @property
    def inertia_matrix(self) -> NDArray[np.float64]:
        return self._matrices["inertia"]

    @property
    def inertia_inverse(self) -> NDArray[np.float64]:
        return self._matrices["inertia_inverse"]

    @property
    def allocation_matrix(self) -> NDArray[np.float64]:
        """4x4 map from rotor thrusts to ``[f, Mx, My, Mz]``."""
        return self._matrices["allocation"]

    @property
    def mixer_matrix(self) -> NDArray[np.float64]:
        """Inverse of the allocation matrix: ``[f, Mx, My, Mz]`` to rotor thrusts."""
        return self._matrices["mixer"]

    @property
    def hover_thrust(self) -> float:
        return self.mass * self.gravity

    @property
    def max_total_thrust(self) -> float:
        return 4 * self.max_rotor_thrust

    def moment_limit(self, actuation: Actuation) -> NDArray[np.float64]:
        """Largest body moment per axis [N m] that the given actuation can produce."""
        if actuation not in ACTUATIONS:
            raise unknown_name_error("actuation", actuation, ACTUATIONS)
        return self._matrices[f"moment_limit_{actuation}"]

    def with_changes(self, **changes: object) -> VehicleParams:
        """A copy with some fields changed, validated like the original."""
        unknown = sorted(set(changes) - set(self.__dataclass_fields__) - {"_matrices"})
        if unknown:
            valid = [f for f in self.__dataclass_fields__ if not f.startswith("_")]
            raise unknown_name_error("VehicleParams field", unknown[0], valid)
        return replace(self, **changes)


def _diagonal(a: float, b: float, c: float) -> tuple[tuple[float, float, float], ...]:
    return ((a, 0.0, 0.0), (0.0, b, 0.0), (0.0, 0.0, c))


# Yaw moment per newton of thrust of the paper vehicle's propeller class (10-inch, R = 0.127 m):
# UIUC Propeller Data Site, APC 10x4.7 Slow Flyer, static test (Brandt & Selig, AIAA
# 2011-1255), C_T = 0.1155 and C_P = 0.0474 at 4319 RPM; Q/T = C_P D / (2π C_T) = 0.0166 m.
APC_10X47_TORQUE_COEFFICIENT = 0.0474 * 0.254 / (2 * math.pi * 0.1155)
# Its thrust per squared rotor speed, k_F = C_T ρ D⁴ / (2π)² with ρ = 1.225 kg/m³ (ISA sea
# level): T = C_T ρ n² D⁴ for n in rev/s.
APC_10X47_THRUST_COEFFICIENT = 0.1155 * 1.225 * 0.254**4 / (2 * math.pi) ** 2
# Lee, Leok, McClamroch 2010 print c_τf = 8.004e-4 m: 20x less than a 10-inch propeller makes,
# at most 0.04 N m of yaw on this vehicle. Kept by name to show what it cannot fly.
LEE_TORQUE_COEFFICIENT = 8.004e-4
# Rotor drag per rotor speed and in-plane airspeed of PX4's x500 (2 kg, ~11-inch rotors;
# PX4-gazebo-models models/x500/model.sdf rotorDragCoefficient, after Martin & Salaün, ICRA
# 2010), the nearest rotor class with a published coefficient; its hubs sit 0.06 m above
# the centre of mass (x500_base/model.sdf), which the paper vehicle is assumed to share.
X500_ROTOR_DRAG_COEFFICIENT = 8.06428e-5
X500_ROTOR_HEIGHT = 0.06
# Thrust of a propeller in oblique flow, Gill & D'Andrea 2019 ("Computationally Efficient
# Force and Moment Models for Propellers in UAV Forward Flight Applications", Drones 3(4) 77,
# §5 eq. 95 and Appendix A): C_T = C_s + k1 λ + k2 μ² + k3 λ², fitted to their wind-tunnel
# runs of an APC 10x4.7 SF at incidences 0-90° (λ = axial, μ = in-plane airspeed over ωR;
# C_T = T / (½ρπR²(ωR)²)). The fit's coefficients (C_s, k1, k2, k3), as their Appendix A
# prints them (copied in enac-drones/dronesim, database/propeller_database.py):
APC_10X47_OBLIQUE_FIT = (0.032, -0.065, 0.17, -0.41)


def oblique_flow_thrust(thrust_coefficient: float, radius: float,
                        fit: tuple[float, float, float, float] = APC_10X47_OBLIQUE_FIT
                        ) -> tuple[float, tuple[float, float]]:
    """A rotor's ``inflow_coefficient`` k_z and ``inflow_quadratic`` (k2/C_s, k3/C_s) from an
    oblique-flow fit, applied as ratios to its own static k_F: T = k_F ω² (1 + k1/C_s λ
    + k2/C_s μ² + k3/C_s λ²), so k_F ω² k1/C_s λ = -k_z ω u_z with k_z = -k_F k1/(C_s R)."""
    static, k1, k2, k3 = fit
    return -thrust_coefficient * k1 / (static * radius), (k2 / static, k3 / static)


# PX4's x500 model (PX4-gazebo-models models/x500/model.sdf, ~11-inch rotors): thrust per
# squared speed (motorConstant), yaw torque per thrust (momentConstant), and the slower of
# its motors' time constants (timeConstantDown; up: 12.5 ms).
X500_THRUST_COEFFICIENT, X500_TORQUE_COEFFICIENT = 8.54858e-6, 0.016
X500_MOTOR_TIME_CONSTANT = 0.025

# Neural-Fly's custom PX4 quadrotor (O'Connell et al., Science Robotics 2022, Tables S1-S2):
# 2.53 kg, thrust/weight 2.2, 11-inch rotors 39 cm apart front to back in a wide X 85 cm
# across (over the rotors: 0.85 - 0.279 m between the motors sideways).
NEURAL_FLY_MASS, NEURAL_FLY_THRUST_TO_WEIGHT = 2.53, 2.2
NEURAL_FLY_HALF_SPACING = (0.39 / 2, (0.85 - 11 * 0.0254) / 2)  # front-back, sideways [m]


@dataclass(frozen=True)
class AirframeDrag:
    """A benchmark's own drag for the airframe it flies, laid over a vehicle preset's
    (``LoopOptions.airframe_drag``): the body's quadratic drag per body axis [N/(m/s)²] and
    the rotors' drag per rotor speed and in-plane airspeed k_d [N/(rad/s · m/s)]. A preset
    keeps its own values, so the benchmarks that fly it stay as they were."""

    body_quadratic: tuple[float, float, float]
    rotor_drag_coefficient: float

    def __post_init__(self) -> None:
        values = np.asarray(self.body_quadratic, dtype=float)
        if values.shape != (3,) or not np.all(np.isfinite(values)) or np.any(values < 0):
            raise ValueError(f"AirframeDrag.body_quadratic must be three finite numbers >= 0 "
                             f"[N/(m/s)²], got {self.body_quadratic!r}")
        object.__setattr__(self, "body_quadratic", tuple(float(v) for v in values))
        k = self.rotor_drag_coefficient
        if not (isinstance(k, (int, float)) and math.isfinite(k) and k >= 0):
            raise ValueError(f"AirframeDrag.rotor_drag_coefficient must be a finite number "
                             f">= 0 [N/(rad/s · m/s)], got {k!r}")
        object.__setattr__(self, "rotor_drag_coefficient", float(k))

    def on(self, vehicle: VehicleParams) -> VehicleParams:
        """``vehicle`` with this drag in place of its own."""
        return replace(vehicle, drag_quadratic=self.body_quadratic,
                       rotor_drag_coefficient=self.rotor_drag_coefficient)


def _point_mass_inertia(mass: float, arm: tuple[float, float], rotor_mass: float,
                        body: tuple[float, float, float]) -> tuple[tuple[float, ...], ...]:
    """Our estimate where a vehicle's inertia is unpublished: four rotor groups of
    ``rotor_mass`` at (±arm[0], ±arm[1]) and the rest a uniform box of sides ``body``."""
    core = mass - 4 * rotor_mass
    a, b, c = body
    x, y = arm
    return _diagonal(4 * rotor_mass * y * y + core * (b * b + c * c) / 12,
                     4 * rotor_mass * x * x + core * (a * a + c * c) / 12,
                     4 * rotor_mass * (x * x + y * y) + core * (a * a + b * b) / 12)


def _body_drag_coefficient(force: float, airspeed: float, mass: float,
                           thrust_coefficient: float, rotor_drag: float) -> float:
    """c₂ [N/(m/s)²] that, with four rotors' drag at hover (k_d ω_h u), makes ``force`` at
    ``airspeed``: ``(F - 4 k_d ω_h u) / u²``."""
    hover_speed = math.sqrt(mass * 9.81 / 4 / thrust_coefficient)
    return (force - 4 * rotor_drag * hover_speed * airspeed) / airspeed**2


# Neural-Fly's measured aerodynamic force in 12.1 m/s of wind, about -15.7 N along the wind
# at the start of custom_figure8_baseline_100wind.csv (aerorobotics/neural-fly's data, near
# hover): a physical measurement, not the tracking errors its figure-8 scenarios are checked
# against. The body's quadratic drag makes what the rotors' drag does not.
NEURAL_FLY_BODY_DRAG = _body_drag_coefficient(15.7, 12.1, NEURAL_FLY_MASS,
                                              X500_THRUST_COEFFICIENT,
                                              X500_ROTOR_DRAG_COEFFICIENT)

NEURAL_FLY_HOVER_SPEED = math.sqrt(NEURAL_FLY_MASS * 9.81 / 4 / X500_THRUST_COEFFICIENT)
NEURAL_FLY_INFLOW, NEURAL_FLY_INFLOW_QUADRATIC = oblique_flow_thrust(X500_THRUST_COEFFICIENT,
                                                                  11 * 0.0254 / 2)
PAPER_INFLOW, PAPER_INFLOW_QUADRATIC = oblique_flow_thrust(APC_10X47_THRUST_COEFFICIENT, 0.127)


# The Crazyflie 2.1 of Crazyswarm2's logs (sources in VEHICLE_SOURCES["crazyflie-2.1"])
CRAZYFLIE_21_MASS = 0.032  # [kg] the logs' info files, the firmware's ctrlLee.mass
CRAZYFLIE_21_THRUST_COEFFICIENT = 2.3e-8  # [N/(rad/s)²] Förster 2015 via rotorpy
# the firmware's fit of one motor's largest thrust [g] at full PWM and a 3.9 V pack
# (IMRCLab crazyflie-firmware motors.c motorsGetMaxThrust: e00 + e10 pwm + e01 v/4.2)
CRAZYFLIE_21_MAX_ROTOR_THRUST = (-10.291152501242268 + 3.926415845326646
                                 + 26.077196474667165 * 3.9 / 4.2) * 9.81e-3
CRAZYFLIE_21_HOVER_SPEED = math.sqrt(CRAZYFLIE_21_MASS * 9.81 / 4
                                     / CRAZYFLIE_21_THRUST_COEFFICIENT)  # [rad/s]
# utiasDSL drone-models (77f04ab, drone_models/data/params.toml, cf2x_L250: a Crazyflie 2.1
# with the legacy propellers, 31.9 g): the linear drag identified in flight, 0.01471782 N/(m/s)
# sideways and 0.01277641 vertically, as the rotors' k_d and k_z at that vehicle's hover
# (4 k ω_h), so it grows with the rotor speed as rotor drag does. Förster 2015's k_d (via
# rotorpy, 10.25e-7) is for the Crazyflie 2.0 and gives half of it
_L250_HOVER_SPEED = math.sqrt(0.0319 * 9.81 / 4 / CRAZYFLIE_21_THRUST_COEFFICIENT)
CRAZYFLIE_21_ROTOR_DRAG = 0.01471782 / (4 * _L250_HOVER_SPEED)  # k_d [N/(rad/s · m/s)]
CRAZYFLIE_21_INFLOW = 0.01277641 / (4 * _L250_HOVER_SPEED)  # k_z

VEHICLES: dict[str, VehicleParams] = {
    "paper": VehicleParams(
        name="paper", mass=4.34, inertia=_diagonal(0.0820, 0.0845, 0.1377), arm_length=0.315,
        torque_coefficient=APC_10X47_TORQUE_COEFFICIENT, max_rotor_thrust=25.0,
        rotor_radius=0.127, configuration="plus",
        drag_linear=(0.3, 0.3, 0.4), drag_quadratic=(0.06, 0.06, 0.1), motor_time_constant=0.04,
        thrust_coefficient=APC_10X47_THRUST_COEFFICIENT,
        rotor_drag_coefficient=X500_ROTOR_DRAG_COEFFICIENT,
        inflow_coefficient=PAPER_INFLOW, inflow_quadratic=PAPER_INFLOW_QUADRATIC,
        rotor_height=X500_ROTOR_HEIGHT,
    ),
    "crazyflie": VehicleParams(
        name="crazyflie", mass=0.027, inertia=_diagonal(1.4e-5, 1.4e-5, 2.17e-5),
        arm_length=0.046, torque_coefficient=7.94e-12 / 3.16e-10,
        max_rotor_thrust=2.25 * 0.027 * 9.81 / 4, rotor_radius=0.0231, configuration="x",
        # Förster 2015: F_aero = K Σω (R^T v), K = diag(10.2506, 10.2506, 7.4064)e-7 kg/rad,
        # at the hover rotor speed Σω = 4 x 1697 rad/s (k_F = 2.3e-8 N/(rad/s)², 27 g)
        drag_linear=(6.96e-3, 6.96e-3, 5.03e-3), drag_quadratic=(0.0, 0.0, 0.0),
        motor_time_constant=0.015, thrust_coefficient=3.16e-10 * (60.0 / (2 * math.pi)) ** 2,
        # Förster 2015 through rotorpy 3 (crazyflie_params.py): k_d, k_z per rotor
        rotor_drag_coefficient=10.2506e-7, inflow_coefficient=7.553e-7, rotor_height=0.0,
    ),
    # The Crazyflie 2.1 as Crazyswarm2's logs flew it (issue 59; docs/research/
    # crazyflie-sources.md): the firmware's own constants where it has them, Förster's
    # identification through rotorpy where it does not. v2's "crazyflie" above is kept as
    # v2 flew it; this one replaces its yaw coefficient (4x the firmware's) and its motor
    # time constant (no source of the class).
    "crazyflie-2.1": VehicleParams(
        name="crazyflie-2.1", mass=CRAZYFLIE_21_MASS,
        inertia=_diagonal(16.571710e-6, 16.655602e-6, 29.261652e-6),
        arm_length=0.046, torque_coefficient=0.0069929, configuration="x",
        max_rotor_thrust=CRAZYFLIE_21_MAX_ROTOR_THRUST, rotor_radius=0.0231,
        thrust_coefficient=CRAZYFLIE_21_THRUST_COEFFICIENT,
        motor_time_constant=0.072,
        # the rotors' drag linearised at hover (4 k_d ω_h sideways, 4 k_z ω_h vertically),
        # what v1's linear drag stands for; rotor aerodynamics replace it where on
        drag_linear=tuple(4 * k * CRAZYFLIE_21_HOVER_SPEED for k in (
            CRAZYFLIE_21_ROTOR_DRAG, CRAZYFLIE_21_ROTOR_DRAG, CRAZYFLIE_21_INFLOW)),
        rotor_drag_coefficient=CRAZYFLIE_21_ROTOR_DRAG,
        inflow_coefficient=CRAZYFLIE_21_INFLOW, rotor_height=0.0,
    ),
    "neural-fly": VehicleParams(
        name="neural-fly", mass=NEURAL_FLY_MASS,
        inertia=_point_mass_inertia(NEURAL_FLY_MASS, NEURAL_FLY_HALF_SPACING, 0.12,
                                    (0.2, 0.15, 0.1)),
        arm_length=NEURAL_FLY_HALF_SPACING[0], arm_width=NEURAL_FLY_HALF_SPACING[1],
        configuration="wide-x", torque_coefficient=X500_TORQUE_COEFFICIENT,
        max_rotor_thrust=NEURAL_FLY_THRUST_TO_WEIGHT * NEURAL_FLY_MASS * 9.81 / 4,
        rotor_radius=11 * 0.0254 / 2, thrust_coefficient=X500_THRUST_COEFFICIENT,
        motor_time_constant=X500_MOTOR_TIME_CONSTANT,
        # v1's linear drag is the rotors' aerodynamics linearised at hover: 4 k_d ω_h
        # sideways, 4 k_z ω_h vertically; the body's quadratic drag makes the rest of the
        # 15.7 N measured at 12.1 m/s (see the sources)
        drag_linear=tuple(4 * k * NEURAL_FLY_HOVER_SPEED for k in (
            X500_ROTOR_DRAG_COEFFICIENT, X500_ROTOR_DRAG_COEFFICIENT, NEURAL_FLY_INFLOW)),
        drag_quadratic=(NEURAL_FLY_BODY_DRAG,) * 2 + (NEURAL_FLY_BODY_DRAG * 0.1 / 0.06,),
        rotor_drag_coefficient=X500_ROTOR_DRAG_COEFFICIENT,
        inflow_coefficient=NEURAL_FLY_INFLOW, inflow_quadratic=NEURAL_FLY_INFLOW_QUADRATIC,
        rotor_height=X500_ROTOR_HEIGHT,
    ),
}



def get_vehicle(vehicle: str | VehicleParams) -> VehicleParams:
    """A preset by name, or the given parameters unchanged."""
    if isinstance(vehicle, VehicleParams):
        return vehicle
    if vehicle not in VEHICLES:
        raise unknown_name_error("vehicle preset", vehicle, sorted(VEHICLES))
    return VEHICLES[vehicle]
