"""``ResidualCommand``: a base controller's command plus a scaled policy residual.

``ResidualCommand`` does it for a whole ``QuadrotorBatch`` (one controller call for all N
vehicles); ``quad_dob_env.wrappers.ResidualActionWrapper`` is its single-env face and
``ResidualQuadrotorVectorEnv`` (``vector_env``) its vector face, so both run this code.
The base is a controller *object* (``reset``, ``compute``, ``applied``): the simulator
knows no controller by name. ``quad_dob_composition`` builds one by name and hands it in,
which is what the registered residual ids do. Two ways to run a step, with the same
per-vehicle equations: the stages ``command`` -> ``core.step`` -> ``record`` -> ``plan``
work with any controller (the wrapper, whose env steps itself, always uses them); ``step``
runs the step in one compiled pass when given one (``fused_pass``, which
``quad_dob_composition`` supplies for the geometric controller in v1's loop and in loops
with sensors and an inner loop; it answers None for others).

Two residual modes (``residual_mode``), each with the residual ``a`` clipped to [-1, 1] and
a zero residual giving the base command exactly:

- ``"thrust_moments"`` (the default): the applied command, before the actuators' own limits,
  is ``thrust = base_thrust + thrust_scale · max_total_thrust · a₀``,
  ``moment_k = base_moment_k + moment_scale · moment_limit_k · a_k`` (k = 1..3).
- ``"acceleration"``: ``a₀..a₂`` are a world-frame acceleration
  ``Δa = acceleration_scale · a₀..₂`` [m/s²] the base adds to its reference acceleration
  (the geometric base's ``F = -kx ex - kv ev + m g e3 + m (ẍd + Δa) - d̂x``, with Δa held
  constant in Ḟ and F̈; ``Controller.accepts_acceleration_correction`` says which bases
  can), and ``a₃`` a yaw moment as above, ``moment_scale · moment_limit_z · a₃``. The
  policy then acts where the position loop acts (two integrations from the position, not
  four through the attitude loop), and the base's attitude loop and the actuators' limits
  still apply to the sum. The base runs once per step, in ``command``, with the
  correction: the observation's entries 0-3 are then the command flown the step before
  (hover at a start) and the observer's estimates those of that step's start state. The
  compiled ``fused_pass`` is for ``"thrust_moments"`` only. A downward correction is
  raised where it would take the desired force's vertical part below ``vertical_floor``
  of the weight (0.5 by default; never above zero): near F = 0 the thrust direction, and
  the attitude the base asks for, swing with every horizontal newton. Without that floor a
  residual trained on random tracks lost 7 of 20 v1 helix flights (tuning seeds 100-119)
  within 0.5 s of the start, where the helix asks for 0.4 g while the motors still spin
  at hover; with it, none.

Its options come as one record, ``ResidualOptions`` (``quad_dob_env.residual.options``).
How much of the residual flies (``authority_gate`` and ``authority_signal``: a gate on the
observed disturbance; ``floor_fade``: a fade near the floor) is ``AuthorityGate``'s
(``gate``) and ``FloorFade``'s (``floor_fade``); the acceleration mode is
``AccelerationMode``'s (``modes``). The base sits behind ``BaseController``.

Observation: the env's own observation followed by 16 entries, from the measurement the
base controller reads:

| index (after the env's) | entry                                                   | unit |
|-------------------------|---------------------------------------------------------|------|
| 0-3                     | base command as a normalised action (thrust, Mx, My, Mz) | -    |
| 4-6                     | observer's force estimate d̂x / (m g) (0 without one)     | -    |
| 7-9                     | observer's torque estimate d̂Ω / moment limit            | -    |
| 10-12                   | position error in the body frame, Rᵀ(x - x_d)           | m    |
| 13-15                   | velocity error in the body frame, Rᵀ(v - v_d)           | m/s  |

The body-frame errors are there because the residual acts through body moments: with them
a correction is nearly linear in what the policy sees, whatever the heading.

Reward: the env's reward (built with no effort term) minus
``residual_effort_weight · mean(a²)``, so only the policy's own effort is penalised, and
minus ``residual_rate_weight · mean((a - a_prev)²)`` (0 by default), a_prev the residual of
the step before (zero at an episode's start): a penalty on the residual's rate of change,
so a policy pays for the step-to-step dither that latency and slow motors turn into
oscillation.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.envs.observation import placed
from quad_dob_env.residual.floor_fade import FloorFade
from quad_dob_env.residual.gate import AuthorityGate
from quad_dob_env.residual.loop_view import LoopView
from quad_dob_env.residual.modes import AccelerationMode
from quad_dob_env.residual.observation import RESIDUAL_ENTRIES
from quad_dob_env.residual.options import ResidualOptions
from quad_dob_env.residual.residual_kernels import (
    join_columns,
    residual_addition_kernel,
    residual_command_kernel,
    residual_observation_kernel,
    residual_reward_kernel,
)
from quad_dob_env.residual.supervisor import Supervisor, attitude_angle
from quad_dob_env.residual.washout import Washout

if TYPE_CHECKING:
    from quad_dob_env.envs.core import QuadrotorBatch

RESIDUAL_OBSERVATION_SIZE = sum(entry.size for entry in RESIDUAL_ENTRIES)


# the extra observation's columns by name (``RESIDUAL_ENTRIES`` placed from column 0)
_COLUMNS = {entry.name: entry.columns for entry in placed(RESIDUAL_ENTRIES)}
# the body-frame velocity error, which the loop view's history keeps
VELOCITY_ERROR_COLUMNS = _COLUMNS["body_velocity_error"]
# the observer's force estimate over m g, which the wind gate reads
FORCE_ESTIMATE_COLUMNS = _COLUMNS["force_estimate"]


@runtime_checkable
class BaseController(Protocol):
    """What a residual's base must offer: the interface of ``quad_dob_baselines.base``'s
    ``Controller``, seen from the simulator (which imports no controller)."""

    name: str
    diagnostics: dict[str, NDArray]

    def reset(self, n: int, vehicle: Any, dt: float, indices: Any = None,
              **options: Any) -> None: ...

    def compute(self, time: float, state: Any, reference: Any,
                **options: Any) -> tuple[NDArray, NDArray]: ...

    def applied(self, state: Any, thrust: NDArray, moment: NDArray) -> None: ...


def check_controller(base: Any) -> BaseController:
    """``base`` if it is a controller object; a name or anything else raises, saying where
    names are resolved."""
    if isinstance(base, str):
        raise ValueError(
            f"base_controller {base!r} is a name: the simulator takes a controller object. "
            "Names are resolved by quad_dob_composition: gym.make / gym.make_vec of a "
            "QuadDOB/...Residual-v1 id with base_controller=NAME, "
            "quad_dob_composition.ResidualVectorEnv or make_residual_env")
    if not (hasattr(base, "compute") and hasattr(base, "reset") and hasattr(base, "applied")):
        raise ValueError(f"base_controller must be a controller (reset, compute, applied), "
                         f"got {base!r}")
    return base


# The recommended base: geometric + NDOB with observer rates chosen by a sweep on tuning
# seeds (docs/benchmark-v1.md); the paper's observer gains are "geometric-ndob".
DEFAULT_BASE_CONTROLLER = "geometric-ndob:tuned"


class ResidualCommand:
    """Base controller + residual for every vehicle of ``core``, with the options
    ``options`` (the defaults without)."""

    def __init__(self, core: QuadrotorBatch, base_controller: Any,
                 options: ResidualOptions | None = None, *,
                 fused_pass: Callable[[ResidualCommand], Any] | None = None,
                 attitude_loop: Callable[[QuadrotorBatch, Any], Any] | None = None) -> None:
        if core.action_map.rate_loop is not None:
            raise ValueError("a residual adds to its base's thrust and moments: "
                             "action_mode='thrust_rates' is for direct control only")
        if options is None:
            options = ResidualOptions()
        elif not isinstance(options, ResidualOptions):
            raise ValueError(f"ResidualCommand takes its options as a ResidualOptions, got "
                             f"{options!r}")
        self.options = options
        self.residual_mode = options.residual_mode
        self.core = core
        n, dt = core.n, core.scenario.dt
        self.gate = (None if options.authority_gate is None else
                     AuthorityGate(n, dt, options.authority_gate, options.authority_signal))
        self.floor_fade = (None if options.floor_fade is None
                           or core.scenario.floor_height is None
                           else FloorFade(options.floor_fade, core.scenario.floor_height))
        self.controller = check_controller(base_controller)
        vehicle, limit = core.vehicle, core.actuator.moment_limit
        self.acceleration = (None if options.residual_mode != "acceleration" else
                             AccelerationMode(self.controller, options.acceleration_scale,
                                              options.vertical_floor, vehicle.mass,
                                              vehicle.gravity))
        self.effort_weight = options.residual_effort_weight
        self.rate_weight = options.residual_rate_weight
        self.residual_range = np.concatenate(
            [[options.thrust_scale * vehicle.max_total_thrust], options.moment_scale * limit])
        self.estimate_scale = np.concatenate([np.full(3, 1.0 / (vehicle.mass * vehicle.gravity)),
                                               1.0 / limit])
        self.base_thrust, self.base_moment = np.zeros(n), np.zeros((n, 3))
        self.requested_thrust = np.zeros(n)  # base + residual, before the actuators' limits
        # what it sees of its loop beyond one instant (``loop_view``), and the safety net
        # (``supervisor``); both None for options that ask for neither
        self.loop_view = (LoopView(n, dt, options, vehicle.mass, vehicle.gravity)
                          if options.observation_entries != RESIDUAL_ENTRIES else None)
        self.supervisor = (None if options.supervisor is None else
                           Supervisor(n, dt, options.supervisor))
        self.washout = (None if options.residual_washout is None else
                        Washout(n, dt, options.residual_washout))
        self._residual_share = np.zeros(n)  # the residual's part of the last command
        self._fresh = np.ones(n, bool)  # no command since the start: no attitude error yet
        self._errors_before = np.zeros((n, 3))  # body-frame velocity errors at a step's start
        self.extra_observation = np.zeros(
            (n, RESIDUAL_OBSERVATION_SIZE + (0 if self.loop_view is None else self.loop_view.size)),
            dtype=np.float32)
        self.rewards = np.zeros(n)
        self._body_errors = np.zeros((n, 6))
        self._base_action = np.zeros((n, 4))
        self._state_before = None
        self.force_estimate, self.torque_estimate = np.zeros((n, 3)), np.zeros((n, 3))
        self._residual = np.zeros((n, 4))
        self.previous_residual = np.zeros((n, 4))  # the residual flown the step before
        # the last step's factors: the gate's, and the gate's times the floor fade's (the
        # one flown); 1 without either
        self.gate_authority, self.authority = np.ones(n), np.ones(n)
        self._started = False
        by_acceleration = self.acceleration is not None
        # the compiled pass flies the base's own command (not the acceleration mode's), in
        # the loops it knows, with no loop view or supervisor; it answers None for any other
        staged = (by_acceleration or self.loop_view is not None or self.supervisor is not None
                  or self.washout is not None)
        self._fused = None if fused_pass is None or staged else fused_pass(self)
        # with an inner loop, the base's attitude law runs at its rate (installed by
        # ``quad_dob_composition``, ``AttitudeLoop.install``), the residual added each tick
        if attitude_loop is not None:
            self._attitude = attitude_loop(core, self.controller)
        elif core.loop.active and getattr(self.controller, "has_inner_law", False):
            raise ValueError(
                f"scenario {core.scenario.name!r} has an inner loop (inner_rate="
                f"{core.scenario.loop.inner_rate:g} Hz) and the base {self.controller.name!r} an "
                "attitude law for it, but nothing was given to run it: build the env through "
                "quad_dob_composition (ResidualVectorEnv, make_residual_env, "
                "residual_command), which passes attitude_loop=AttitudeLoop.install")
        else:
            self._attitude = None
            if hasattr(self.controller, "use_inner_loop"):
                self.controller.use_inner_loop(None)

    def restart(self, indices: NDArray[np.intp]) -> None:
        """After ``core.reset(indices)``: restart those vehicles' controller state (all of
        them the first time) and plan their first base command."""
        core = self.core
        if not self._started or len(indices) == core.n:
            self.controller.reset(core.n, core.vehicle, core.scenario.dt,
                                  actuation=core.scenario.actuation)
            self._started = True
        else:
            self.controller.reset(core.n, core.vehicle, core.scenario.dt, indices,
                                  actuation=core.scenario.actuation)
        self.rewards[indices] = 0.0
        self.previous_residual[indices] = 0.0  # an episode starts from the base alone
        if self.gate is not None:
            self.gate.restart(indices)
        if self.supervisor is not None:
            self.supervisor.restart(indices)
        if self.washout is not None:
            self.washout.restart(indices)
        self._residual_share[indices] = 0.0
        self._fresh[indices] = True
        if self.loop_view is not None:
            self.loop_view.restart(indices)
        if self.residual_mode == "acceleration":
            # the base runs in ``command``: until a vehicle's first one it shows hover, no
            # residual and no estimate
            hover = core.vehicle.mass * core.vehicle.gravity
            self.base_thrust[indices] = self.requested_thrust[indices] = hover
            for array in (self.base_moment, self._residual, self.force_estimate,
                          self.torque_estimate):
                array[indices] = 0.0
        if self._fused is None:
            self.plan()
        else:
            self._fused.restart(indices)
            self._write_loop_view()

    def step(self, residual: NDArray[np.float64]) -> None:
        """Step the core with base + ``residual`` (N, 4) and plan the next base command:
        one compiled pass when it was given one (``fused_pass``), else ``command``,
        ``core.step``, ``record`` and ``plan``."""
        if self._fused is not None:
            self._fused.step(self._gate_flown(residual))
            return
        self.core.step(self.command(residual))
        self.record()
        self.plan()

    def command(self, residual: NDArray[np.float64]) -> NDArray[np.float64]:
        """The env actions (N, 4) for base command + scaled ``residual`` (N, 4)."""
        if not self._started:
            raise RuntimeError("ResidualCommand.restart must run before command")
        core = self.core
        measurement = core.measurement
        self._state_before = measurement.copy()
        self._errors_before[...] = self.extra_observation[:, VELOCITY_ERROR_COLUMNS]
        actions = np.empty((core.n, 4))
        residual = np.ascontiguousarray(self._gate_flown(residual), dtype=np.float64)
        if self.washout is not None:  # after the authority, as residual:v4 trained (washout)
            residual = self.washout.flown(np.clip(residual, -1.0, 1.0))
        if self.acceleration is not None:
            clipped = np.clip(residual, -1.0, 1.0)
            self.base_thrust, self.base_moment = self.acceleration.correct(
                core.time, measurement, core.reference, clipped)
            zeros = np.zeros((core.n, 3))
            self.force_estimate, self.torque_estimate = (
                self.controller.diagnostics.get(key, zeros).copy()
                for key in ("force_estimate", "torque_estimate"))
            residual = np.zeros_like(clipped)
            residual[:, 3] = clipped[:, 3]  # the yaw moment: the only part added after it
        residual_command_kernel(0, core.n, residual,
                                self.residual_range, np.ascontiguousarray(self.base_thrust),
                                np.ascontiguousarray(self.base_moment), core.action_map.inverse,
                                self._residual, self.requested_thrust, actions)
        if self._attitude is not None:  # what the inner loop adds to its law at every tick
            residual_addition_kernel(0, core.n, self._residual, self.residual_range,
                                     self._attitude.addition)
        if self.residual_mode == "acceleration":
            self._residual = clipped  # the effort term scores the whole residual
        return actions

    def _gate_flown(self, residual: NDArray[np.float64]) -> NDArray[np.float64]:
        """``gated``, the ``"wind"`` filter and the supervisor advanced first: once per
        flown step."""
        if self.gate is not None:  # the "wind" signal's low-pass, at the step's start
            self.gate.advance(self.extra_observation[:, FORCE_ESTIMATE_COLUMNS])
        if self.supervisor is not None:
            self.supervisor.advance(*self._supervised_signals())
        return self.gated(residual)

    def _supervised_signals(self) -> tuple[NDArray, NDArray, NDArray]:
        """The supervisor's measured signals at the step's start (``supervisor``): body rate,
        the tilt error to the base's last desired thrust axis, the residual's share."""
        measurement = self.core.measurement
        body_rate = np.linalg.norm(measurement.angular_velocity, axis=1)
        desired = self.controller.diagnostics.get("desired_rotation")
        if desired is None:
            if not self._fresh.all():
                raise ValueError(f"the residual's supervisor reads the attitude the base asks "
                                 f"for (diagnostics['desired_rotation']), which "
                                 f"{self.controller.name!r} does not report")
            attitude_error = np.zeros(self.core.n)
        else:
            attitude_error = np.where(self._fresh, 0.0,
                                      attitude_angle(measurement.rotation, desired))
        return body_rate, attitude_error, self._residual_share

    def gated(self, residual: NDArray[np.float64]) -> NDArray[np.float64]:
        """``residual`` clipped and scaled by the authority the observed disturbance and the
        height above the floor give (``gate``, ``floor_fade``); unchanged without
        ``authority_gate`` and ``floor_fade``. Sets ``gate_authority`` and ``authority``
        only."""
        if self.gate is None and self.floor_fade is None and self.supervisor is None:
            return residual
        authority = np.ones(self.core.n)
        if self.gate is not None:
            authority = self.gate.factor(self.extra_observation[:, FORCE_ESTIMATE_COLUMNS])
        self.gate_authority = authority
        if self.floor_fade is not None:
            authority = authority * self.floor_fade.factor(self.core.measurement.position)
        if self.supervisor is not None:
            authority = authority * self.supervisor.factor
        self.authority = authority
        return np.clip(residual, -1.0, 1.0) * authority[:, None]

    def record(self) -> None:
        """After the core flew ``command``'s actions: tell the controller what was applied
        and score the residual's effort."""
        core = self.core
        told = core.estimator_wrench  # what a real stack's estimators have (LoopOptions)
        self.controller.applied(self._state_before, told.thrust, told.moment)
        self.rewards = np.empty(core.n)  # a new array: the one handed out stays as it was
        residual_reward_kernel(0, core.n, self._residual, core.rewards, self.effort_weight,
                               self.rate_weight, self.previous_residual,
                               self.rewards)
        self._fresh[:] = False
        if self.supervisor is not None:
            self._residual_share = self._share_of_command()
        if self.loop_view is not None:  # previous_residual now holds the residual flown
            self.loop_view.advance(self._errors_before, self.previous_residual,
                                   core.measurement.accelerometer[:, 2], core.commanded.thrust)

    def _share_of_command(self) -> NDArray[np.float64]:
        """The residual's part of the command just flown: ``‖m Δa‖ / ‖F_base‖`` in the
        acceleration mode (F_base the base's desired force without Δa), ``|ΔT| / T_base``
        in the thrust-and-moment mode."""
        if self.acceleration is not None:
            mass = self.core.vehicle.mass
            correction = mass * self.acceleration.scale * self._residual[:, :3]
            base_force = self.controller.diagnostics["desired_force"] - correction
            return (np.linalg.norm(correction, axis=1)
                    / np.maximum(np.linalg.norm(base_force, axis=1), 1e-9))
        return (np.abs(self._residual[:, 0] * self.residual_range[0])
                / np.maximum(np.abs(self.base_thrust), 1e-9))
    def plan(self) -> None:
        """Every vehicle's base command for the coming step, and the extra observation."""
        core, controller = self.core, self.controller
        measurement = core.measurement
        if self.residual_mode == "acceleration":
            # the base ran in ``command``: the observation shows the command flown and the
            # estimates of that step's start state
            seen_thrust, seen_moment = self.requested_command()
        else:
            self.base_thrust, self.base_moment = controller.compute(core.time, measurement,
                                                                    core.reference)
            zeros = np.zeros((core.n, 3))
            self.force_estimate = controller.diagnostics.get("force_estimate", zeros)
            self.torque_estimate = controller.diagnostics.get("torque_estimate", zeros)
            seen_thrust, seen_moment = self.base_thrust, self.base_moment
        state = measurement
        residual_observation_kernel(
            np.ascontiguousarray(seen_thrust, dtype=np.float64),
            np.ascontiguousarray(seen_moment, dtype=np.float64),
            np.ascontiguousarray(self.force_estimate, dtype=np.float64),
            np.ascontiguousarray(self.torque_estimate, dtype=np.float64), self.estimate_scale,
            state.position, state.velocity, state.rotation, core.reference_table,
            core.reference_row, core.action_map.inverse, self._base_action, self._body_errors,
            self.extra_observation)
        self._write_loop_view()

    def _write_loop_view(self) -> None:
        if self.loop_view is not None:
            core = self.core  # the reference the step about to be flown tracks
            self.loop_view.write(self.extra_observation, RESIDUAL_OBSERVATION_SIZE,
                                 core.reference_table[core.reference_row, 3])

    def requested_command(self, base_moment: NDArray | None = None
                          ) -> tuple[NDArray, NDArray]:
        """The thrust (N,) and moments (N, 3) of the last ``command``, base plus residual,
        before the actuators' limits. ``base_moment``: the base's moment that command
        added to (after a step the plan holds the next step's base; the acceleration
        mode's base runs within the step, so it is the one held)."""
        moment = (self.base_moment if base_moment is None else base_moment).copy()
        moment[:, 2] += self._residual[:, 3] * self.residual_range[3]
        if self.residual_mode == "thrust_moments":
            moment[:, :2] += self._residual[:, 1:3] * self.residual_range[1:3]
        return self.requested_thrust.copy(), moment

    def info(self) -> dict[str, NDArray]:
        """``base_thrust`` (N,), ``base_moment`` and the observer's ``force_estimate`` and
        ``torque_estimate`` (N, 3; zero without an observer), for the coming step."""
        arrays = {"base_thrust": self.base_thrust, "base_moment": self.base_moment,
                  "force_estimate": self.force_estimate, "torque_estimate": self.torque_estimate}
        if self.supervisor is not None:
            arrays["supervision"] = self.supervisor.factor
        return {name: value.copy() for name, value in arrays.items()}

    def observation(self, core_observation: NDArray[np.float32]) -> NDArray[np.float32]:
        extra = self.extra_observation
        joined = np.empty((len(extra), core_observation.shape[1] + extra.shape[1]), np.float32)
        join_columns(core_observation, extra, joined)
        return joined
