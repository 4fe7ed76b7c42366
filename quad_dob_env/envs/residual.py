"""Residual control: a base controller's command plus a scaled policy residual.

``ResidualCommand`` does it for a whole ``QuadrotorBatch`` (one controller call for all N
vehicles); ``quad_dob_env.wrappers.ResidualActionWrapper`` is its single-env face and
``QuadrotorVectorEnv(..., base_controller=...)`` its vector face, so both run this code.
The base is a controller *object* (``reset``, ``compute``, ``applied``): the simulator
knows no controller by name. ``quad_dob_composition`` builds one by name and hands it in,
which is what the registered residual ids do. Two ways to run a step, with the same
per-vehicle equations: the stages ``command`` -> ``core.step`` -> ``record`` -> ``plan``
work with any controller (the wrapper, whose env steps itself, always uses them); ``fly``
runs the step in one compiled pass when given one (``fused_pass``, which
``quad_dob_composition`` supplies for the geometric controller).

Applied command (before the actuators' own limits):
``thrust = base_thrust + thrust_scale · max_total_thrust · a₀``,
``moment_k = base_moment_k + moment_scale · moment_limit_k · a_k`` (k = 1..3),
with the residual ``a`` clipped to [-1, 1]. A zero residual gives the base command exactly.
With ``authority_gate`` = g (a fraction of the weight), ``a`` is first multiplied by
``clip(2 ‖d̂x‖ / (g m g₀) - 1, 0, 1)``, from the force disturbance the observer sees now (the
observation's entries 4-6): below half the gate (nothing, or the observer's own small model
error, disturbs the vehicle) the residual has no authority and the base flies alone, bit
for bit; from the gate up it has all of it.

Observation: the env's own observation followed by 16 entries, from the state the base
controller reads:

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
``residual_effort_weight · mean(a²)``, so only the policy's own effort is penalised.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.envs.residual_kernels import (
    join_columns,
    residual_command_kernel,
    residual_observation_kernel,
    residual_reward_kernel,
)
from quad_dob_env.validation import as_finite

if TYPE_CHECKING:
    from quad_dob_env.envs.core import QuadrotorBatch

RESIDUAL_OBSERVATION_SIZE = 16


def check_controller(base: Any) -> Any:
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
# seeds (README, "Fair baselines"); the paper's observer gains are "geometric-ndob".
DEFAULT_BASE_CONTROLLER = "geometric-ndob:tuned"


class ResidualCommand:
    """Base controller + residual for every vehicle of ``core``."""

    def __init__(self, core: QuadrotorBatch, base_controller: Any,
                 thrust_scale: float = 0.1, moment_scale: float = 0.1,
                 residual_effort_weight: float = 0.01,
                 fused_pass: Callable[[ResidualCommand], Any] | None = None,
                 authority_gate: float | None = None) -> None:
        if core.action_map.rate_loop is not None:
            raise ValueError("a residual adds to its base's thrust and moments: "
                             "action_mode='thrust_rates' is for direct control only")
        self.core = core
        self.authority_gate = (None if authority_gate is None else
                               as_finite(authority_gate, "authority_gate", 0.0, strictly=True))
        self.controller = check_controller(base_controller)
        self.thrust_scale = as_finite(thrust_scale, "residual thrust_scale", 0.0, strictly=True)
        self.moment_scale = as_finite(moment_scale, "residual moment_scale", 0.0, strictly=True)
        if self.thrust_scale > 1 or self.moment_scale > 1:
            raise ValueError(f"residual thrust_scale and moment_scale are fractions of the "
                             f"limits in (0, 1], got {thrust_scale}, {moment_scale}")
        self.effort_weight = as_finite(residual_effort_weight, "residual_effort_weight", 0.0)
        vehicle, limit = core.vehicle, core.actuator.moment_limit
        self.residual_range = np.concatenate([[self.thrust_scale * vehicle.max_total_thrust],
                                               self.moment_scale * limit])
        self.estimate_scale = np.concatenate([np.full(3, 1.0 / (vehicle.mass * vehicle.gravity)),
                                               1.0 / limit])
        n = core.n
        self.base_thrust, self.base_moment = np.zeros(n), np.zeros((n, 3))
        self.requested_thrust = np.zeros(n)  # base + residual, before the actuators' limits
        self.extra_observation = np.zeros((n, RESIDUAL_OBSERVATION_SIZE), dtype=np.float32)
        self.rewards = np.zeros(n)
        self._body_errors = np.zeros((n, 6))
        self._base_action = np.zeros((n, 4))
        self._state_before = None
        self.force_estimate, self.torque_estimate = np.zeros((n, 3)), np.zeros((n, 3))
        self._residual = np.zeros((n, 4))
        self._started = False
        self._fused = None if fused_pass is None else fused_pass(self)

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
        if self._fused is None:
            self.plan()
        else:
            self._fused.restart(indices)

    def fly(self, residual: NDArray[np.float64]) -> None:
        """Step the core with base + ``residual`` (N, 4) and plan the next base command:
        one compiled pass when it was given one (``fused_pass``), else ``command``,
        ``core.step``, ``record`` and ``plan``."""
        if self._fused is not None:
            self._fused.fly(self.gated(residual))
            return
        self.core.step(self.command(residual))
        self.record()
        self.plan()

    def command(self, residual: NDArray[np.float64]) -> NDArray[np.float64]:
        """The env actions (N, 4) for base command + scaled ``residual`` (N, 4)."""
        if not self._started:
            raise RuntimeError("ResidualCommand.restart must run before command")
        core = self.core
        self._state_before = core.state.copy()
        actions = np.empty((core.n, 4))
        residual = self.gated(residual)
        residual_command_kernel(0, core.n, np.ascontiguousarray(residual, dtype=np.float64),
                                self.residual_range, np.ascontiguousarray(self.base_thrust),
                                np.ascontiguousarray(self.base_moment), core.action_map.inverse,
                                self._residual, self.requested_thrust, actions)
        return actions

    def gated(self, residual: NDArray[np.float64]) -> NDArray[np.float64]:
        """``residual`` clipped and scaled by the authority the observed disturbance gives
        (module docstring); unchanged without ``authority_gate``."""
        if self.authority_gate is None:
            return residual
        seen = np.linalg.norm(self.extra_observation[:, 4:7], axis=1)  # |d̂x| / (m g)
        authority = np.clip(2.0 * seen / self.authority_gate - 1.0, 0.0, 1.0)
        return np.clip(residual, -1.0, 1.0) * authority[:, None]

    def record(self) -> None:
        """After the core flew ``command``'s actions: tell the controller what was applied
        and score the residual's effort."""
        core = self.core
        self.controller.applied(self._state_before, core.applied.thrust, core.applied.moment)
        self.rewards = np.empty(core.n)  # a new array: the one handed out stays as it was
        residual_reward_kernel(0, core.n, self._residual, core.rewards, self.effort_weight,
                               self.rewards)

    def plan(self) -> None:
        """Every vehicle's base command for the coming step, and the extra observation."""
        core, controller = self.core, self.controller
        self.base_thrust, self.base_moment = controller.compute(core.time, core.state,
                                                                core.reference)
        zeros = np.zeros((core.n, 3))
        self.force_estimate = controller.diagnostics.get("force_estimate", zeros)
        self.torque_estimate = controller.diagnostics.get("torque_estimate", zeros)
        state = core.state
        residual_observation_kernel(
            np.ascontiguousarray(self.base_thrust, dtype=np.float64),
            np.ascontiguousarray(self.base_moment, dtype=np.float64),
            np.ascontiguousarray(self.force_estimate, dtype=np.float64),
            np.ascontiguousarray(self.torque_estimate, dtype=np.float64), self.estimate_scale,
            state.position, state.velocity, state.rotation, core.reference_table,
            core.reference_row, core.action_map.inverse, self._base_action, self._body_errors,
            self.extra_observation)

    def info(self) -> dict[str, NDArray]:
        """``base_thrust`` (N,), ``base_moment`` and the observer's ``force_estimate`` and
        ``torque_estimate`` (N, 3; zero without an observer), for the coming step."""
        arrays = {"base_thrust": self.base_thrust, "base_moment": self.base_moment,
                  "force_estimate": self.force_estimate, "torque_estimate": self.torque_estimate}
        return {name: value.copy() for name, value in arrays.items()}

    def observation(self, core_observation: NDArray[np.float32]) -> NDArray[np.float32]:
        extra = self.extra_observation
        joined = np.empty((len(extra), core_observation.shape[1] + extra.shape[1]), np.float32)
        join_columns(core_observation, extra, joined)
        return joined
