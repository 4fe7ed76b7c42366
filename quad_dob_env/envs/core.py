"""The batched environment core: N vehicles of one scenario, stepped together.

``QuadrotorEnv`` is its N = 1 view; a vector env runs the same object with N > 1, so the
physics, observation, reward and termination are written once.

Every vehicle's time is ``step_count * dt``, so whatever depends on time alone (the
reference and the non-random disturbances) is tabulated once on that grid, and one
compiled call per step does the rest for the whole batch: action -> command -> actuation ->
integration -> observation, reward, termination.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from quad_dob_env.disturbances import Disturbance, Sum
from quad_dob_env.dynamics import (
    NO_GROUND_EFFECT,
    PARALLEL_MIN_BATCH,
    Actuator,
    AppliedCommand,
    VehicleState,
    actuate_vehicle,
    actuator_wrench,
    advance_vehicle,
    all_finite,
    body_drag,
    lag_factor,
    load_vehicle,
    physics_arrays,
    sample,
    store_applied,
    store_vehicle,
    thrust_multiplier_scalar,
    vehicle_physics,
)
from quad_dob_env.scenarios import Scenario
from quad_dob_env.so3 import exp as so3_exp
from quad_dob_env.so3 import mat_vec_tuple
from quad_dob_env.trajectories import Reference
from quad_dob_env.validation import as_finite, unknown_name_error

ACTION_MODES = ("thrust_moments", "rotor_thrusts")
ROTATION_REPRESENTATIONS = {"matrix": 9, "6d": 6}
# Index 0 means "still flying"; the rest are info["termination_reason"] values.
TERMINATION_REASONS = ("", "crashed", "out_of_bounds", "attitude_lost", "non_finite_state")
TIME_LIMIT = "time_limit"
# Observations are clamped to float32's range, so a huge but finite state never becomes inf.
OBSERVATION_BOUND = float(np.finfo(np.float32).max)
_REFERENCE_FIELDS = [f.name for f in fields(Reference)]


@dataclass(frozen=True)
class EpisodeLimits:
    """When an episode ends early (``terminated``); all documented in ``QuadrotorEnv``."""

    max_position_error: float = 5.0  # [m] from the reference
    max_tilt: float = np.pi / 2  # [rad] between body z and world z
    max_body_rate: float = 35.0  # [rad/s], any axis

    def __post_init__(self) -> None:
        as_finite(self.max_position_error, "max_position_error", 0.0, strictly=True)
        as_finite(self.max_tilt, "max_tilt", 0.0, strictly=True)
        if self.max_tilt > np.pi:
            raise ValueError(f"max_tilt must be <= pi, got {self.max_tilt}")
        as_finite(self.max_body_rate, "max_body_rate", 0.0, strictly=True)


@dataclass(frozen=True)
class RewardWeights:
    """``reward = exp(-|e_x| / position_scale) - effort_weight * mean(action²)``."""

    position_scale: float = 0.25  # [m]
    effort_weight: float = 0.01

    def __post_init__(self) -> None:
        as_finite(self.position_scale, "reward position_scale", 0.0, strictly=True)
        as_finite(self.effort_weight, "reward effort_weight", 0.0)


# --- compiled per-vehicle pieces ---------------------------------------------------------

@njit(cache=True, inline="always")
def _command(actions, i, rotor_mode, centre, scale_up, scale_down, allocation):
    """Normalised action -> commanded thrust and moment; 0 maps to hover."""
    s = [0.0, 0.0, 0.0, 0.0]
    for k in range(4):
        a = min(max(actions[i, k], -1.0), 1.0)  # out-of-range actions are clipped
        s[k] = centre[k] + a * (scale_up[k] if a >= 0.0 else scale_down[k])
    if rotor_mode:
        f = s[0] + s[1] + s[2] + s[3]
        m = [0.0, 0.0, 0.0]
        for row in range(3):
            for k in range(4):
                m[row] += allocation[row + 1, k] * s[k]
        return f, (m[0], m[1], m[2])
    return s[0], (s[1], s[2], s[3])


@njit(cache=True, inline="always")
def _bounded(value):
    return min(max(value, -OBSERVATION_BOUND), OBSERVATION_BOUND)


@njit(cache=True)
def _sense(i, x, v, R, w, reference, row, rotation_mode, limits, obs):
    """Write vehicle i's observation; return its termination code and position error."""
    max_error, cos_max_tilt, max_rate, has_floor, floor = limits
    error_sq = 0.0
    for k in range(3):
        e_x = x[k] - reference[row, 0, k]
        error_sq += e_x * e_x
        obs[i, k] = _bounded(e_x)
        obs[i, 3 + k] = _bounded(v[k] - reference[row, 1, k])
    if rotation_mode == 0:  # R row-major
        for k in range(9):
            obs[i, 6 + k] = R[k]
        j = 15
    else:  # R's first two columns, one after the other
        for c in range(2):
            for r in range(3):
                obs[i, 6 + 3 * c + r] = R[3 * r + c]
        j = 12
    for k in range(3):
        obs[i, j + k] = _bounded(w[k])
        obs[i, j + 3 + k] = reference[row, 2, k]  # desired acceleration
        obs[i, j + 6 + k] = reference[row, 5, k]  # desired heading b1d
    error = np.sqrt(error_sq)
    code = 0
    if error > max_error:
        code = 2
    if R[8] < cos_max_tilt or max(abs(w[0]), abs(w[1]), abs(w[2])) > max_rate:
        code = 3
    if has_floor and x[2] < floor:
        code = 1
    return code, error


def _step_kernel(actions, action_map, actuation, actuator, position, velocity, rotation,
                 angular_velocity, step_count, tables, own, reference, physics, dt, substeps,
                 law, limits, reward_weights, rotation_mode, obs, reward, code, applied_thrust,
                 applied_moment, rotor_thrusts, saturated, disturbance_force,
                 disturbance_torque):
    rotor_mode, centre, scale_up, scale_down, allocation = action_map
    to_wrench, to_rotors, time_constant, actuator_state = actuator
    mass, gravity, inertia, inertia_inverse, drag = physics
    force_table, torque_table, wind_table = tables
    force_own, torque_own, wind_own = own
    position_scale, effort_weight = reward_weights
    last = force_table.shape[1] - 1
    # share of the old actuator output in the step's mean, and left at its end
    if time_constant > 0.0:
        mean_factor = time_constant / dt * (1.0 - np.exp(-dt / time_constant))
    else:
        mean_factor = 0.0
    end_factor = lag_factor(dt, time_constant)
    for i in prange(actions.shape[0]):
        f_cmd, m_cmd = _command(actions, i, rotor_mode, centre, scale_up, scale_down, allocation)
        command, saturated[i] = actuate_vehicle(f_cmd, m_cmd, *actuation)
        start = (actuator_state[i, 0], actuator_state[i, 1], actuator_state[i, 2],
                 actuator_state[i, 3])
        mean = _blend(start, command, mean_factor)
        store_applied(i, mean, to_wrench, to_rotors, applied_thrust, applied_moment,
                      rotor_thrusts)
        end = _blend(start, command, end_factor)
        for k in range(4):
            actuator_state[i, k] = end[k]
        row = step_count[i]
        vehicle = vehicle_physics(i, mass, gravity, inertia, inertia_inverse, drag)
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        xn, vn, Rn, wn = advance_vehicle(x, v, R, w, start, command, time_constant, to_wrench,
                                         tables, row, own, i, vehicle, dt, substeps, law)
        diverged = not all_finite(xn, vn, Rn, wn)
        if not diverged:
            x, v, R, w = xn, vn, Rn, wn
            store_vehicle(i, position, velocity, rotation, angular_velocity, x, v, R, w)
        step_count[i] = row + 1
        code[i], error = _sense(i, x, v, R, w, reference, row + 1, rotation_mode, limits, obs)
        if diverged:
            code[i] = 4
        effort = 0.0
        for k in range(4):
            effort += min(actions[i, k] * actions[i, k], 1.0)
        reward[i] = np.exp(-error / position_scale) - effort_weight * effort / 4.0
        # the true disturbance now: external force and torque, the ground effect's extra
        # lift and the aerodynamic drag
        thrust_now = actuator_wrench(end, end, 0.0, to_wrench)[0]
        extra_lift = (thrust_multiplier_scalar(x[2], law) - 1.0) * thrust_now
        wind = sample(wind_table, row, wind_own, i, last)
        drag_body = body_drag(v, R, wind, vehicle[4], vehicle[5])
        drag_world = mat_vec_tuple(R, (drag_body[0], drag_body[1], drag_body[2] + extra_lift))
        external = sample(force_table, row, force_own, i, last)
        torque = sample(torque_table, row, torque_own, i, last)
        for k in range(3):
            disturbance_force[i, k] = external[k] + drag_world[k]
            disturbance_torque[i, k] = torque[k]


@njit(cache=True, inline="always")
def _blend(start, command, factor):
    return (command[0] + (start[0] - command[0]) * factor,
            command[1] + (start[1] - command[1]) * factor,
            command[2] + (start[2] - command[2]) * factor,
            command[3] + (start[3] - command[3]) * factor)


_step_serial = njit(cache=True)(_step_kernel)
_step_parallel = njit(cache=True, parallel=True)(_step_kernel)


@njit(cache=True)
def _sense_kernel(indices, position, velocity, rotation, angular_velocity, step_count,
                  reference, rotation_mode, limits, obs, code):
    for i in indices:
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        code[i], _ = _sense(i, x, v, R, w, reference, step_count[i], rotation_mode, limits, obs)


# --- the core ----------------------------------------------------------------------------

class QuadrotorBatch:
    """N vehicles flying ``scenario`` under normalised actions in [-1, 1]^4."""

    def __init__(self, scenario: Scenario, num_vehicles: int = 1,
                 action_mode: str = "thrust_moments", rotation_representation: str = "matrix",
                 limits: EpisodeLimits | None = None, reward: RewardWeights | None = None) -> None:
        if action_mode not in ACTION_MODES:
            raise unknown_name_error("action_mode", action_mode, ACTION_MODES)
        if rotation_representation not in ROTATION_REPRESENTATIONS:
            raise unknown_name_error("rotation_representation", rotation_representation,
                                     ROTATION_REPRESENTATIONS)
        if not isinstance(num_vehicles, (int, np.integer)) or num_vehicles < 1:
            raise ValueError(f"num_vehicles must be an integer >= 1, got {num_vehicles!r}")
        self.scenario = scenario
        self.n = n = int(num_vehicles)
        self.action_mode = action_mode
        self.rotation_representation = rotation_representation
        self.limits = limits or EpisodeLimits()
        self.reward_weights = reward or RewardWeights()
        self.vehicle = scenario.vehicle
        self.actuator = Actuator(self.vehicle, scenario.actuation)
        self.observation_size = 3 + 3 + ROTATION_REPRESENTATIONS[rotation_representation] + 3 + 6
        self.thrust_law = (NO_GROUND_EFFECT if scenario.ground_effect is None
                           else scenario.ground_effect.law(self.vehicle, scenario.floor_height))
        self._law = tuple(float(value) for value in self.thrust_law)
        samples = 2 * scenario.substeps + 1
        self._sample_offsets = np.arange(samples) * (scenario.dt / (samples - 1))
        self._split_disturbance(scenario.disturbance)
        self._tabulate(scenario.steps + 1)
        self.state = VehicleState.at_rest(n)
        self.step_count = np.zeros(n, dtype=np.int64)
        self.termination_code = np.zeros(n, dtype=np.int8)
        self.obs = np.zeros((n, self.observation_size), dtype=np.float32)
        self.rewards = np.zeros(n)
        self.applied = AppliedCommand(np.zeros(n), np.zeros((n, 3)), np.zeros((n, 4)),
                                      np.zeros(n, dtype=np.bool_))
        self.disturbance_force = np.zeros((n, 3))
        self.disturbance_torque = np.zeros((n, 3))
        self._own = tuple(np.zeros((n, samples, 3)) for _ in range(3))  # force, torque, wind
        # per-vehicle physics (mass, inertia, inverse, drag), so vehicles can differ
        self.mass, self.inertia, self.inertia_inverse, self.drag = physics_arrays(
            self.vehicle, n, scenario.drag)
        self.actuator_state = np.zeros((n, 4))
        self._action_scales()
        self._actuation = self.actuator.kernel_arguments()
        time_constant = self.vehicle.motor_time_constant if scenario.motor_lag else 0.0
        self._actuator = (self.actuator.to_wrench, self.actuator.to_rotors, float(time_constant),
                          self.actuator_state)
        limits_ = self.limits
        floor = scenario.floor_height
        self._limits = (float(limits_.max_position_error), float(np.cos(limits_.max_tilt)),
                        float(limits_.max_body_rate), floor is not None,
                        0.0 if floor is None else float(floor))
        self._reward = (float(self.reward_weights.position_scale),
                        float(self.reward_weights.effort_weight))
        self._rotation_mode = 0 if rotation_representation == "matrix" else 1

    def _split_disturbance(self, disturbance: Disturbance | None) -> None:
        """Tabulate what depends on time alone; keep random parts to evaluate each step."""
        parts = [] if disturbance is None else (
            disturbance.parts if isinstance(disturbance, Sum) else [disturbance])
        # each core owns its random models, whose per-vehicle parameters live in the object
        random = [copy.deepcopy(p) for p in parts if p.is_random]
        self._timed_parts = [p for p in parts if not p.is_random]
        self.random_disturbance = None if not random else (
            random[0] if len(random) == 1 else Sum(random))
        if self.random_disturbance is not None:
            self.random_disturbance.bind(self.n, self.scenario.dt)

    def _tabulate(self, rows: int) -> None:
        """Reference and time-only disturbances on the grid ``t = step * dt``, ``rows`` steps."""
        dt = self.scenario.dt
        times = np.arange(rows) * dt
        ref = self.scenario.trajectory.evaluate(times)
        self._reference_table = np.ascontiguousarray(
            np.stack([getattr(ref, name) for name in _REFERENCE_FIELDS], axis=1))
        grid = times[:, None] + self._sample_offsets
        channels = [np.zeros((*grid.shape, 3)) for _ in range(3)]  # force, torque, wind
        for part in self._timed_parts:
            for total, channel in zip(channels, part.evaluate(grid), strict=True):
                total += channel
        self._tables = tuple(channels)

    def _action_scales(self) -> None:
        """Piecewise-linear maps with action 0 at hover: [-1, 0, 1] -> [0, hover, max]."""
        v = self.vehicle
        if self.action_mode == "thrust_moments":
            moment = self.actuator.moment_limit
            self._centre = np.array([v.hover_thrust, 0.0, 0.0, 0.0])
            self._scale_up = np.concatenate([[v.max_total_thrust - v.hover_thrust], moment])
            self._scale_down = np.concatenate([[v.hover_thrust], moment])
        else:
            per_rotor = v.hover_thrust / 4
            self._centre = np.full(4, per_rotor)
            self._scale_up = np.full(4, v.max_rotor_thrust - per_rotor)
            self._scale_down = np.full(4, per_rotor)
        self._action_map = (self.action_mode == "rotor_thrusts", self._centre, self._scale_up,
                            self._scale_down, v.allocation_matrix)

    def action_from_command(self, thrust: NDArray, moment: NDArray) -> NDArray[np.float64]:
        """The normalised actions (N, 4) that command ``thrust`` and ``moment``: the inverse
        of the action map, clipped to [-1, 1] (so beyond the limits it saturates)."""
        wrench = np.concatenate([np.asarray(thrust, float).reshape(-1, 1),
                                 np.asarray(moment, float).reshape(-1, 3)], axis=1)
        if self.action_mode == "rotor_thrusts":
            wrench = wrench @ self.vehicle.mixer_matrix.T
        offset = wrench - self._centre
        actions = offset / np.where(offset >= 0, self._scale_up, self._scale_down)
        return np.clip(actions, -1.0, 1.0)

    # --- time and reference ---------------------------------------------------------------
    @property
    def time(self) -> NDArray[np.float64]:
        """Per-vehicle time [s]; a multiple of dt, so it never drifts."""
        return self.step_count * self.scenario.dt

    @property
    def reference(self) -> Reference:
        """The reference at each vehicle's current time, (N, 3) per field."""
        rows = self._reference_table[self.step_count]
        return Reference(*(rows[:, j] for j in range(len(_REFERENCE_FIELDS))))

    def reference_row(self, index: int) -> NDArray[np.float64]:
        """(8, 3) reference of vehicle ``index`` now, rows in ``Reference`` field order."""
        return self._reference_table[self.step_count[index]]

    # --- reset ----------------------------------------------------------------------------
    def reset(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        """Start a new episode for vehicles ``indices``, drawing from ``rngs`` (one each)."""
        indices = np.asarray(indices, dtype=np.intp)
        if len(rngs) != len(indices):
            raise ValueError(f"reset needs one generator per vehicle: {len(indices)} vehicles, "
                             f"{len(rngs)} generators")
        sc = self.scenario
        count = len(indices)
        position_offset = np.zeros((count, 3))
        attitude_offset = np.zeros((count, 3))
        for j, rng in enumerate(rngs):
            # fixed draw order per vehicle: position, then attitude, then the disturbance
            position_offset[j] = rng.uniform(-1.0, 1.0, 3) * sc.initial_position_noise
            attitude_offset[j] = rng.uniform(-1.0, 1.0, 3) * sc.initial_attitude_noise
        self.state.assign(VehicleState(
            position=np.asarray(sc.initial_position) + position_offset,
            velocity=np.broadcast_to(np.asarray(sc.initial_velocity), (count, 3)),
            rotation=sc.initial_rotation_matrix() @ so3_exp(attitude_offset),
            angular_velocity=np.broadcast_to(np.asarray(sc.initial_angular_velocity), (count, 3)),
        ), indices)
        if self.random_disturbance is not None:
            self.random_disturbance.resample(indices, rngs)
        self.step_count[indices] = 0
        for array in (*self.applied, self.disturbance_force, self.disturbance_torque,
                      self.rewards):
            array[indices] = 0
        self.actuator_state[indices] = self.actuator.hover_output()
        s = self.state
        _sense_kernel(indices, s.position, s.velocity, s.rotation, s.angular_velocity,
                      self.step_count, self._reference_table, self._rotation_mode, self._limits,
                      self.obs, self.termination_code)

    # --- step -----------------------------------------------------------------------------
    def step(self, actions: NDArray[np.float64]) -> None:
        """Fly one control step from finite normalised actions (N, 4); values beyond
        [-1, 1] are clipped (the reward's effort term sees the clipped values).

        Updates ``state``, ``obs``, ``rewards``, ``termination_code``, ``applied`` and the
        true ``disturbance_force`` / ``disturbance_torque``.
        """
        rows = self._reference_table.shape[0]
        if self.step_count.max() + 1 >= rows:  # flown past the scenario's end: extend
            self._tabulate(2 * rows)
        if self.random_disturbance is not None:
            for own in self._own:
                own.fill(0.0)
            self.random_disturbance.add_to(self.time[:, None] + self._sample_offsets,
                                           *self._own)
        kernel = _step_parallel if self.n >= PARALLEL_MIN_BATCH else _step_serial
        s, sc = self.state, self.scenario
        kernel(actions, self._action_map, self._actuation, self._actuator, s.position,
               s.velocity, s.rotation, s.angular_velocity, self.step_count, self._tables,
               self._own, self._reference_table,
               (self.mass, self.vehicle.gravity, self.inertia, self.inertia_inverse, self.drag),
               sc.dt, sc.substeps, self._law, self._limits, self._reward, self._rotation_mode,
               self.obs, self.rewards, self.termination_code, self.applied.thrust,
               self.applied.moment, self.applied.rotor_thrusts, self.applied.saturated,
               self.disturbance_force, self.disturbance_torque)

    @property
    def terminated(self) -> NDArray[np.bool_]:
        return self.termination_code > 0

    @property
    def truncated(self) -> NDArray[np.bool_]:
        return (self.step_count >= self.scenario.steps) & ~self.terminated

    def termination_reason(self, index: int) -> str:
        """``info["termination_reason"]`` for a vehicle whose episode ended, else ''."""
        code = int(self.termination_code[index])
        if code:
            return TERMINATION_REASONS[code]
        return TIME_LIMIT if self.step_count[index] >= self.scenario.steps else ""
