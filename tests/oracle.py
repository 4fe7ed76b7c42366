"""An independent oracle: the equations of docs/design.md in plain numpy, sharing no code with
the package (it reads only public fields of ``VehicleParams`` and samples references).

Everything here is written for clarity and checked to tight tolerances against the package,
never for speed:

- ``rigid_body_step``: ``x' = v``, ``m v' = -m g e3 + k(h) f R e3 + R F_drag + d_x``,
  ``R' = R hat(Ω)``, ``J Ω' = -Ω × JΩ + M + d_Ω`` with the first-order actuator lag, the
  drag on ``u = Rᵀ(v - w)`` and, optionally, the NDOB's z in continuous form, all integrated
  together by classical RK4 on the 3x3 matrix R with many small steps.
- ``mix``: the rotor allocation from the geometry, each rotor clipped to [0, f_max], yaw at
  the lowest priority; or the wrench clipped per axis.
- ``lee_command``: Lee, Leok, McClamroch 2010 (z up) with the observer's estimates; Ωd and
  Ω̇d by finite differences of Rd along the thrust vector's Taylor expansion, not by the
  product rule the package uses.
- ``fly``: the closed loop of the three, one control step at a time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

E3 = np.array([0.0, 0.0, 1.0])


def hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def vee(s: np.ndarray) -> np.ndarray:
    return np.array([s[2, 1], s[0, 2], s[1, 0]])


def orthonormalize(r: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(r)
    return u @ vt


@dataclass
class Vehicle:
    """The numbers of one vehicle, read from a ``VehicleParams``'s public fields."""

    mass: float
    gravity: float
    inertia: np.ndarray
    arm: float
    yaw_per_thrust: float
    max_rotor: float
    rotor_radius: float
    plus: bool
    drag_linear: np.ndarray
    drag_quadratic: np.ndarray
    motor_tau: float

    @classmethod
    def of(cls, params, drag: bool = False, motor_lag: bool = False) -> Vehicle:
        return cls(params.mass, params.gravity, np.array(params.inertia, dtype=float),
                   params.arm_length, params.torque_coefficient, params.max_rotor_thrust,
                   params.rotor_radius, params.configuration == "plus",
                   np.array(params.drag_linear) * drag, np.array(params.drag_quadratic) * drag,
                   params.motor_time_constant if motor_lag else 0.0)

    def allocation(self) -> np.ndarray:
        """[f, Mx, My, Mz] = A t. Plus: rotors on +x, +y, -x, -y; X: front-right, front-left,
        back-left, back-right; rotor k at (px, py) rolls by py t, pitches by -px t; the
        spins alternate, starting clockwise seen from above (-1)."""
        if self.plus:
            xy = self.arm * np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
        else:
            xy = self.arm / np.sqrt(2.0) * np.array([[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0],
                                                     [-1.0, -1.0]])
        spins = np.array([-1.0, 1.0, -1.0, 1.0])
        return np.array([np.ones(4), xy[:, 1], -xy[:, 0], spins * self.yaw_per_thrust])

    def wrench_limits(self) -> tuple[float, np.ndarray]:
        """Wrench actuation: thrust up to 4 f_max, every moment up to the roll authority."""
        roll = self.arm * self.max_rotor * (1.0 if self.plus else np.sqrt(2.0))
        return 4 * self.max_rotor, np.full(3, roll)


def mix(vehicle: Vehicle, thrust: float, moment: np.ndarray, actuation: str) -> np.ndarray:
    """The actuator output for a command: four rotor thrusts, or the clipped wrench."""
    if actuation == "wrench":
        top, limits = vehicle.wrench_limits()
        return np.concatenate([[np.clip(thrust, 0.0, top)], np.clip(moment, -limits, limits)])
    inverse = np.linalg.inv(vehicle.allocation())
    base = np.clip(inverse @ np.array([thrust, moment[0], moment[1], 0.0]), 0.0,
                   vehicle.max_rotor)
    yaw = inverse @ np.array([0.0, 0.0, 0.0, moment[2]])
    # the largest share s of the yaw with every rotor inside [0, f_max], by bisection
    low, high = 0.0, 1.0
    if np.all((base + yaw >= -1e-12) & (base + yaw <= vehicle.max_rotor + 1e-12)):
        low = 1.0
    for _ in range(80):
        if low == 1.0:
            break
        middle = 0.5 * (low + high)
        rotors = base + middle * yaw
        if np.all((rotors >= 0.0) & (rotors <= vehicle.max_rotor)):
            low = middle
        else:
            high = middle
    return base + low * yaw


def to_wrench(vehicle: Vehicle, output: np.ndarray, actuation: str) -> np.ndarray:
    return output if actuation == "wrench" else vehicle.allocation() @ output


@dataclass
class Environment:
    """What acts on the vehicle besides its rotors, as functions of time (and height)."""

    force: callable = lambda t: np.zeros(3)  # world [N]
    torque: callable = lambda t: np.zeros(3)  # body [N m]
    wind: callable = lambda t: np.zeros(3)  # world [m/s]
    ground: tuple | None = None  # (coefficient, exponent, radius, floor, min h, cutoff h)

    def lift_factor(self, z: float) -> float:
        if self.ground is None:
            return 1.0
        coefficient, exponent, radius, floor, lowest, cutoff = self.ground
        height = z - floor
        if height >= cutoff:
            return 1.0
        return 1.0 / (1.0 - coefficient * (radius / max(height, lowest)) ** exponent)


@dataclass
class Observer:
    """NDOB gains in continuous form: Ks [kg/s], Km [3x3]."""

    ks: float
    km: np.ndarray


def _derivative(t, y, vehicle, environment, actuation, command, observer):
    x, v, r, w = y[0:3], y[3:6], y[6:15].reshape(3, 3), y[15:18]
    output = y[18:22]
    thrust, *moment = to_wrench(vehicle, output, actuation)
    moment = np.array(moment)
    air = r.T @ (v - environment.wind(t))
    drag_body = -(vehicle.drag_linear * air + np.linalg.norm(air) * vehicle.drag_quadratic * air)
    lift = environment.lift_factor(x[2]) * thrust
    m, J = vehicle.mass, vehicle.inertia
    acceleration = (-m * vehicle.gravity * E3 + r @ (lift * E3 + drag_body)
                    + environment.force(t)) / m
    angular = np.linalg.solve(J, -np.cross(w, J @ w) + moment + environment.torque(t))
    lag = np.zeros(4) if vehicle.motor_tau == 0 else (command - output) / vehicle.motor_tau
    dy = np.concatenate([v, acceleration, (r @ hat(w)).reshape(9), angular, lag, np.zeros(6)])
    if observer is not None:
        # żx = -(Ks/m)(zx + Ks v - m g e3 + f R e3);  żΩ = -Km J⁻¹(zΩ + Km Ω - Ω × JΩ + M)
        z_force, z_torque = y[22:25], y[25:28]
        dy[22:25] = -(observer.ks / m) * (z_force + observer.ks * v - m * vehicle.gravity * E3
                                          + thrust * (r @ E3))
        dy[25:28] = -observer.km @ np.linalg.solve(
            J, z_torque + observer.km @ w - np.cross(w, J @ w) + moment)
    return dy


def rigid_body_step(y, t, dt, vehicle, environment, actuation, command, observer=None,
                    steps: int = 200):
    """``y`` = [x, v, R (9), Ω, actuator output (4), zx, zΩ] after ``dt``, by RK4 in
    ``steps`` pieces, the actuator output relaxing towards ``command`` (at once without lag)."""
    y = np.array(y, dtype=float)
    if vehicle.motor_tau == 0:
        y[18:22] = command
    h = dt / steps
    for k in range(steps):
        s = t + k * h
        k1 = _derivative(s, y, vehicle, environment, actuation, command, observer)
        k2 = _derivative(s + h / 2, y + h / 2 * k1, vehicle, environment, actuation, command,
                         observer)
        k3 = _derivative(s + h / 2, y + h / 2 * k2, vehicle, environment, actuation, command,
                         observer)
        k4 = _derivative(s + h, y + h * k3, vehicle, environment, actuation, command, observer)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    y[6:15] = orthonormalize(y[6:15].reshape(3, 3)).reshape(9)
    return y


def _desired_rotation(force, heading):
    b3 = force / np.linalg.norm(force)
    b2 = np.cross(b3, heading)
    b2 /= np.linalg.norm(b2)
    return np.column_stack([np.cross(b2, b3), b2, b3])


def lee_command(x, v, r, w, ref, vehicle, gains, force_estimate, torque_estimate):
    """Lee 2010 with NDOB compensation. ``ref``: (xd, ẋd, ẍd, x⃛d, x⃜d, b1d, ḃ1d, b̈1d) for
    one vehicle; ``gains``: kx, kv (per unit mass), kR, kΩ. Returns (f, M, Rd)."""
    xd, vd, ad, jd, sd, b1, b1_dot, b1_ddot = ref
    m, g, J = vehicle.mass, vehicle.gravity, vehicle.inertia
    kx, kv, k_r, k_w = m * gains[0], m * gains[1], gains[2], gains[3]
    ex, ev = x - xd, v - vd
    force = -kx * ex - kv * ev + m * g * E3 + m * ad - force_estimate
    f = force @ (r @ E3)
    # the thrust vector's derivatives along the model's prediction of the errors
    b3_dot = r @ hat(w) @ E3
    ea = (f * (r @ E3) + force_estimate) / m - g * E3 - ad
    force_dot = -kx * ev - kv * ea + m * jd
    f_dot = force_dot @ (r @ E3) + force @ b3_dot
    ej = (f_dot * (r @ E3) + f * b3_dot) / m - jd
    force_ddot = -kx * ea - kv * ej + m * sd

    def rd_at(tau):
        return _desired_rotation(force + force_dot * tau + force_ddot * tau**2 / 2,
                                 b1 + b1_dot * tau + b1_ddot * tau**2 / 2)

    def derivative(function, tau, h=1e-3):  # 4th-order central difference
        return (function(tau - 2 * h) - 8 * function(tau - h) + 8 * function(tau + h)
                - function(tau + 2 * h)) / (12 * h)

    def rate_at(tau):  # Ωd = vee(Rdᵀ Ṙd)
        return vee(rd_at(tau).T @ derivative(rd_at, tau))

    rd = rd_at(0.0)
    rate_d, rate_d_dot = rate_at(0.0), derivative(rate_at, 0.0)
    e_r = 0.5 * vee(rd.T @ r - r.T @ rd)
    e_w = w - r.T @ rd @ rate_d
    moment = (-k_r * e_r - k_w * e_w + np.cross(w, J @ w)
              - J @ (hat(w) @ r.T @ rd @ rate_d - r.T @ rd @ rate_d_dot) - torque_estimate)
    return f, moment, rd


def fly(scenario, vehicle: Vehicle, environment: Environment, gains, observer: Observer | None,
        steps: int, substeps: int = 40):
    """The closed loop, one control step of ``scenario.dt`` at a time: positions (steps+1, 3)
    and the last force estimate."""
    dt = scenario.dt
    x = np.array(scenario.initial_position, dtype=float)
    r = np.array(scenario.initial_rotation, dtype=float)
    v = np.array(scenario.initial_velocity, dtype=float)
    w = np.array(scenario.initial_angular_velocity, dtype=float)
    hover = np.linalg.solve(vehicle.allocation(), [vehicle.mass * vehicle.gravity, 0, 0, 0]) \
        if scenario.actuation == "rotors" else np.array([vehicle.mass * vehicle.gravity, 0, 0, 0])
    y = np.concatenate([x, v, r.reshape(9), w, hover, np.zeros(6)])
    if observer is not None:  # a fresh observer's first estimate is zero
        y[22:25], y[25:28] = -observer.ks * v, -observer.km @ w
    positions, estimate = [x.copy()], np.zeros(3)
    for k in range(steps):
        t = k * dt
        ref = scenario.trajectory.evaluate(t)
        ref = tuple(getattr(ref, name)[0] for name in (
            "position", "velocity", "acceleration", "jerk", "snap", "heading", "heading_rate",
            "heading_acceleration"))
        x, v, r, w = y[0:3], y[3:6], y[6:15].reshape(3, 3), y[15:18]
        if observer is None:
            estimate, torque_estimate = np.zeros(3), np.zeros(3)
        else:
            estimate = y[22:25] + observer.ks * v
            torque_estimate = y[25:28] + observer.km @ w
        f, moment, _ = lee_command(x, v, r, w, ref, vehicle, gains, estimate, torque_estimate)
        command = mix(vehicle, f, moment, scenario.actuation)
        y = rigid_body_step(y, t, dt, vehicle, environment, scenario.actuation, command,
                            observer, substeps)
        positions.append(y[0:3].copy())
    return np.array(positions), estimate
