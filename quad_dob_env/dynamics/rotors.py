"""The rotors' own physics (Benchmark v2): motors on rotor speed, thrust uncertainty and
rotor aerodynamics, compiled per vehicle for the integrator.

Each factor is a switch (``RotorModel``); with all of them off the integrator keeps v1's
actuator (rotor thrusts or the wrench, lagged directly) and nothing here runs.

- **Motors on rotor speed** (``speed_motors``): each rotor's speed follows its command
  ``ω_c = sqrt(T_c / k_F)`` as ``ω̇ = (ω_c - ω) / τ`` (exact over a step:
  ``ω(t) = ω_c + (ω₀ - ω_c) e^{-t/τ}``), τ the spin-up time constant where ``ω_c > ω₀``
  and the spin-down one (``spin_down_time_constant``, 0: the same) where it is below: a
  first-order lag never crosses its command, so the direction holds over the interval, and
  an ESC without active braking slows a rotor by its drag alone; thrust ``T = k_F ω²`` and
  yaw torque ``Q = c_τ k_F ω²`` (c_τ the vehicle's torque per thrust), so both go as ω².
  Speeds lie in ``[0, sqrt(max_rotor_thrust / k_F)]`` because the mixer clips the thrusts it
  asks for.
- **The throttle** (``throttle``, Benchmark v3, ``dynamics.throttle``): between the mixer
  and the motors, the thrust a throttle gives and the autopilot's belief of it; the speed
  command is then ``ω_c = sqrt(T / (κ_s k_F))`` for the true rotor thrust T.
- **Thrust uncertainty** (``thrust_uncertainty``): the true ``k_F`` (and with it the yaw
  torque) is the nominal times a per-episode ``thrust_scale`` (air density), and the
  battery's sag scales every command's thrust by ``(1 - sag_rate t)²`` (open-loop ESCs:
  speed per command goes with the pack voltage, thrust with its square).
- **Rotor aerodynamics** (``aerodynamics``), per rotor at its hub's air-relative velocity
  ``u = Rᵀ(v - w) + Ω × p`` (body frame): rotor drag ("H-force", blade flapping and induced
  drag) ``D = -k_d ω (u_x, u_y, 0)``, acting at the hub, so it makes a moment ``p × D``
  about the centre of mass, and the change of thrust with the airflow through and across
  the disc, ``T = k_F ω² (1 + a_μ μ² + a_λ max(λ, 0)²) - k_z ω u_z`` with
  ``λ = u_z/(ωR)``, ``μ = |u_xy|/(ωR)``: Gill & D'Andrea 2019's oblique-flow fit
  (``VehicleParams.inflow_quadratic``; k_z is its linear term), each ratio held within
  ±``FIT_LIMIT``, the fit's range (a rotor spinning slowly in a descent gains at most
  0.3·|k1|/C_s of its static thrust), and λ's square only for inflow from above, where it
  was measured. The linear law of a vehicle without the fit (the Crazyflie's, rotorpy's)
  is held the same way. The rotor's yaw torque stays ``c_τ k_F ω²``, its change with
  inflow left out. These replace the linear body drag (``drag_linear``), which stood for
  the rotors' drag.

What the controllers are told was applied (``AppliedCommand``) is what the nominal model
gives for the rotors' speeds, ``k_F ω²`` through the allocation matrix: an autopilot's best
knowledge from its ESC telemetry. The rest, the true wrench minus that, is part of the true
disturbance the env reports (``disturbance_force``/``disturbance_torque``), as the ground
effect's extra lift is.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.dynamics.actuation import as_floats, as_rows
from quad_dob_env.dynamics.throttle import ThrottleMap
from quad_dob_env.params import VehicleParams


class RotorModel(NamedTuple):
    """Which of the rotors' factors a flight has, and their coefficients: the record the
    compiled step reads by field (``active``: any factor on, so the rotors' own model
    runs). No field has a default: numba would compile an array default into the kernels
    as a global constant, which cannot be cached; ``of`` builds it."""

    speed_motors: bool
    thrust_uncertainty: bool
    aerodynamics: bool
    thrust_coefficient: float  # nominal k_F [N/(rad/s)²]
    drag_coefficient: float  # k_d [N/(rad/s · m/s)]
    inflow_coefficient: float  # k_z [N/(rad/s · m/s)]
    positions: tuple  # 4 hubs (x, y, z) in the body frame [m]
    spin: tuple  # 4: the allocation's yaw signs times c_τ [m]
    radius: float  # R [m]
    edgewise_ratio: float  # a_μ
    axial_ratio: float  # a_λ
    # the throttle between mixer and rotors (``dynamics.throttle``; speed motors): on, the
    # autopilot's κ_ap, and the believed hover thrust per rotor T̂_h [N] (the rotors' own κ
    # is each vehicle's, ``RotorDraws.thrust_model_factor``)
    throttle: bool
    autopilot_thrust_model_factor: float
    believed_hover_rotor_thrust: float
    active: bool

    @classmethod
    def of(cls, vehicle: VehicleParams, speed_motors: bool, thrust_uncertainty: bool,
           aerodynamics: bool, throttle: ThrottleMap | None = None) -> RotorModel:
        allocation = vehicle.allocation_matrix
        # the allocation's moment rows: Mx = py T, My = -px T, Mz = spin c_τ T
        positions = np.stack([-allocation[2], allocation[1],
                              np.full(4, vehicle.rotor_height)], axis=1)
        return cls(
            speed_motors=bool(speed_motors), thrust_uncertainty=bool(thrust_uncertainty),
            aerodynamics=bool(aerodynamics),
            thrust_coefficient=float(vehicle.thrust_coefficient),
            drag_coefficient=float(vehicle.rotor_drag_coefficient),
            inflow_coefficient=float(vehicle.inflow_coefficient),
            positions=as_rows(positions), spin=as_floats(allocation[3]),
            radius=float(vehicle.rotor_radius),
            edgewise_ratio=float(vehicle.inflow_quadratic[0]),
            axial_ratio=float(vehicle.inflow_quadratic[1]),
            throttle=throttle is not None,
            autopilot_thrust_model_factor=(0.0 if throttle is None
                                           else throttle.autopilot_thrust_model_factor),
            believed_hover_rotor_thrust=float(vehicle.hover_thrust / 4),
            active=bool(speed_motors or thrust_uncertainty or aerodynamics
                        or throttle is not None))


class RotorDraws(NamedTuple):
    """Each vehicle's values of its thrust path, (N,) each, set at a reset
    (``envs.vehicle_loop``): per-vehicle arrays, so an episode may draw its own."""

    # [s] the actuators' lag (spin-up on speed motors; 0: none) and the rotor speed's when
    # it slows (0: the spin-up one), the margin's motor_time_constant_scale applied
    time_constant: NDArray
    spin_down_time_constant: NDArray
    thrust_model_factor: NDArray  # the rotors' κ of the throttle map (0 without one)
    thrust_scale: NDArray  # the true k_F over the nominal
    sag_rate: NDArray  # [1/s] the battery's sag: the command's thrust goes as (1 - r t)²
    hover_throttle: NDArray  # the throttle map's true hover throttle at the start
    hover_throttle_drift: NDArray  # [1/s] its climb
    hover_estimate_factor: NDArray  # the autopilot's estimate over the truth, 1 + ε
    rotor_thrust_factor: NDArray  # (N, 4) each rotor's true k_F over the vehicle's


class VehicleDraws(NamedTuple):
    """Vehicle i's row of ``RotorDraws``, read once a step (``vehicle_draws``): numbers
    only, so the per-tick functions it is handed to count no references."""

    time_constant: float
    spin_down_time_constant: float
    thrust_model_factor: float
    thrust_scale: float
    sag_rate: float
    hover_throttle: float
    hover_throttle_drift: float
    hover_estimate_factor: float
    true_thrust_scales: tuple  # (4,) ``true_thrust_scales``


@njit(cache=True, inline="always")
def vehicle_draws(i, draws):
    """Vehicle i's ``VehicleDraws`` from the batch's ``RotorDraws``."""
    return VehicleDraws(draws.time_constant[i], draws.spin_down_time_constant[i],
                        draws.thrust_model_factor[i], draws.thrust_scale[i],
                        draws.sag_rate[i], draws.hover_throttle[i],
                        draws.hover_throttle_drift[i], draws.hover_estimate_factor[i],
                        true_thrust_scales(i, draws))


@njit(cache=True, inline="always")
def true_thrust_scales(i, draws):
    """Vehicle i's four rotors' true thrust coefficients over the nominal k_F, as the rotors'
    wrench reads them: the one place a per-rotor factor of the draws enters the physics."""
    scale, factor = draws.thrust_scale[i], draws.rotor_thrust_factor
    return (scale * factor[i, 0], scale * factor[i, 1], scale * factor[i, 2],
            scale * factor[i, 3])


# The largest advance ratios (λ, μ) the thrust law uses: where Gill & D'Andrea's data and
# their models stop (μ, λ < 0.3); beyond it the ratio is held.
FIT_LIMIT = 0.3


@njit(cache=True, inline="always")
def lagged_output(start, command, factor):
    """The four actuator outputs ``command + (start - command) factor`` of a first-order lag
    (factor: the share of the old output left)."""
    return (command[0] + (start[0] - command[0]) * factor,
            command[1] + (start[1] - command[1]) * factor,
            command[2] + (start[2] - command[2]) * factor,
            command[3] + (start[3] - command[3]) * factor)


@njit(cache=True, inline="always")
def speed_lag_factors(start, command, spin_up, spin_down, elapsed):
    """Per rotor, the share of its old speed left after ``elapsed`` s: ``e^{-t/τ}`` with the
    spin-up time constant where the command is above the speed, else the spin-down one."""
    up = math.exp(-elapsed / spin_up) if spin_up > 0.0 else 0.0
    down = math.exp(-elapsed / spin_down) if spin_down > 0.0 else 0.0
    return (up if command[0] > start[0] else down, up if command[1] > start[1] else down,
            up if command[2] > start[2] else down, up if command[3] > start[3] else down)


@njit(cache=True, inline="always")
def lagged_each(start, command, factors):
    """``lagged_output`` with a factor per output."""
    return (command[0] + (start[0] - command[0]) * factors[0],
            command[1] + (start[1] - command[1]) * factors[1],
            command[2] + (start[2] - command[2]) * factors[2],
            command[3] + (start[3] - command[3]) * factors[3])


@njit(cache=True, inline="always")
def speed_of_thrust(thrust, thrust_coefficient):
    """``ω = sqrt(T / k_F)`` [rad/s], T clipped at 0."""
    return math.sqrt(max(thrust, 0.0) / thrust_coefficient)


@njit(cache=True, inline="always")
def speeds_of_output(output, rotors):
    """The rotor speeds an actuator output stands for: the output itself on speed motors,
    else the speeds of its rotor thrusts."""
    if rotors.speed_motors:
        return output
    k = rotors.thrust_coefficient
    return (speed_of_thrust(output[0], k), speed_of_thrust(output[1], k),
            speed_of_thrust(output[2], k), speed_of_thrust(output[3], k))


@njit(cache=True, inline="always")
def motor_target(thrusts, command_scale, rotors):
    """What the motors move to for the mixer's rotor ``thrusts``, the battery's
    ``command_scale`` applied: speeds on speed motors, else thrusts."""
    if rotors.speed_motors:
        k = rotors.thrust_coefficient / command_scale  # ω_c = sqrt(s T / k_F)
        return (speed_of_thrust(thrusts[0], k), speed_of_thrust(thrusts[1], k),
                speed_of_thrust(thrusts[2], k), speed_of_thrust(thrusts[3], k))
    return (thrusts[0] * command_scale, thrusts[1] * command_scale,
            thrusts[2] * command_scale, thrusts[3] * command_scale)


@njit(cache=True)
def rotor_wrench(speeds, v, rotation, omega, wind, thrust_scales, rotors):
    """The rotors' true force (body frame) and moment about the centre of mass at rotor
    ``speeds``, for a vehicle at velocity ``v``, attitude ``rotation`` (row-major 9-tuple),
    body rates ``omega`` in air moving at ``wind``, each rotor's true k_F its nominal times
    ``thrust_scales`` (``true_thrust_scales``). Returns ((Fx, Fy, Fz), (Mx, My, Mz))."""
    aerodynamics, k_f = rotors.aerodynamics, rotors.thrust_coefficient
    k_d, k_z = rotors.drag_coefficient, rotors.inflow_coefficient
    positions, spin, radius = rotors.positions, rotors.spin, rotors.radius
    a_mu, a_lambda = rotors.edgewise_ratio, rotors.axial_ratio
    r = rotation
    a = (v[0] - wind[0], v[1] - wind[1], v[2] - wind[2])
    body = (r[0] * a[0] + r[3] * a[1] + r[6] * a[2], r[1] * a[0] + r[4] * a[1] + r[7] * a[2],
            r[2] * a[0] + r[5] * a[1] + r[8] * a[2])
    fx = fy = fz = mx = my = mz = 0.0
    for k in range(4):
        px, py, pz = positions[k]
        w = speeds[k]
        thrust = thrust_scales[k] * k_f * w * w
        torque = spin[k] * thrust  # the rotor's drag torque, ∝ ω² (inflow left out of it)
        dx = dy = 0.0
        if aerodynamics:
            # the hub's air-relative velocity u = Rᵀ(v - w) + Ω × p
            ux = body[0] + omega[1] * pz - omega[2] * py
            uy = body[1] + omega[2] * px - omega[0] * pz
            uz = body[2] + omega[0] * py - omega[1] * px
            tip = w * radius
            if tip > 0.0:  # Gill & D'Andrea 2019 eq. 95, as ratios to the static thrust
                lam = max(min(uz / tip, FIT_LIMIT), -FIT_LIMIT)
                mu = min(math.sqrt(ux * ux + uy * uy) / tip, FIT_LIMIT)
                climb = max(lam, 0.0)
                thrust = max(thrust + k_f * w * w * (a_mu * mu * mu + a_lambda * climb * climb)
                             - k_z * w * lam * tip, 0.0)  # ... - k_z ω u_z
            dx, dy = -k_d * w * ux, -k_d * w * uy  # D = -k_d ω (u_x, u_y, 0)
        fx += dx
        fy += dy
        fz += thrust
        # p × (Dx, Dy, T), and the rotor's drag torque spin c_τ κ k_F ω² about its axis
        mx += py * thrust - pz * dy
        my += pz * dx - px * thrust
        mz += px * dy - py * dx + torque
    return (fx, fy, fz), (mx, my, mz)


@njit(cache=True, inline="always")
def nominal_wrench(speeds, rotors, allocation):
    """What the nominal model gives for rotor ``speeds``: k_F ω² through the allocation,
    as f, (Mx, My, Mz) and the four thrusts."""
    k = rotors.thrust_coefficient
    t = (k * speeds[0] * speeds[0], k * speeds[1] * speeds[1], k * speeds[2] * speeds[2],
         k * speeds[3] * speeds[3])
    a = allocation  # 4 rows of 4 (``actuation.as_rows``)
    return (a[0][0] * t[0] + a[0][1] * t[1] + a[0][2] * t[2] + a[0][3] * t[3],
            (a[1][0] * t[0] + a[1][1] * t[1] + a[1][2] * t[2] + a[1][3] * t[3],
             a[2][0] * t[0] + a[2][1] * t[1] + a[2][2] * t[2] + a[2][3] * t[3],
             a[3][0] * t[0] + a[3][1] * t[1] + a[3][2] * t[2] + a[3][3] * t[3]), t)


@njit(cache=True, inline="always")
def _square_means(tau, elapsed):
    """``m₁ = τ/T (1 - e^{-T/τ})``, ``m₂ = τ/(2T) (1 - e^{-2T/τ})``: the means of e^{-t/τ}
    and e^{-2t/τ} over T = ``elapsed`` s (τ = 0: none left)."""
    if tau > 0.0:
        return (tau / elapsed * (1.0 - math.exp(-elapsed / tau)),
                tau / (2.0 * elapsed) * (1.0 - math.exp(-2.0 * elapsed / tau)))
    return 0.0, 0.0


@njit(cache=True, inline="always")
def mean_square_speeds(start, command, tau, elapsed, spin_down=0.0):
    """The mean of ω(t)² over ``elapsed`` s for ``ω = c + (s - c) e^{-t/τ}``:
    ``c² + 2 c (s - c) m₁ + (s - c)² m₂`` (``_square_means``); with ``spin_down`` > 0,
    the rotors not speeding up (c <= s) take that time constant instead of ``tau``."""
    m1, m2 = _square_means(tau, elapsed)
    d1, d2 = _square_means(spin_down, elapsed) if spin_down > 0.0 else (m1, m2)
    return (_mean_square(start[0], command[0], m1, m2, d1, d2),
            _mean_square(start[1], command[1], m1, m2, d1, d2),
            _mean_square(start[2], command[2], m1, m2, d1, d2),
            _mean_square(start[3], command[3], m1, m2, d1, d2))


@njit(cache=True, inline="always")
def _mean_square(start, c, m1, m2, d1, d2):
    """One rotor's mean of ω² (``mean_square_speeds``): spinning up with (m1, m2), else
    with the spin-down's (d1, d2)."""
    d = start - c
    if c > start:
        return c * c + 2.0 * c * d * m1 + d * d * m2
    return c * c + 2.0 * c * d * d1 + d * d * d2
