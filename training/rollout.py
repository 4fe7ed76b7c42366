"""Fly a controller through a scenario and keep everything that happened.

The same records feed ``quad-dob paper``'s tables and figures and, later, evaluation, so
every report computes its metrics from one kind of data.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields

import numpy as np
from gymnasium.utils import seeding
from numpy.typing import NDArray

from baselines.base import Controller
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.scenarios import Scenario
from quad_dob_env.trajectories import Reference


@dataclass
class Flight:
    """Per-step arrays of one episode (index k = time k dt, before the k-th command)."""

    scenario: str
    controller: str
    dt: float
    thrust_limit: float
    time: NDArray
    position: NDArray
    velocity: NDArray
    acceleration: NDArray  # true, from applied thrust and disturbance
    rotation: NDArray
    reference_position: NDArray
    reference_velocity: NDArray
    reference_acceleration: NDArray
    desired_rotation: NDArray
    requested_thrust: NDArray
    applied_thrust: NDArray
    disturbance_force: NDArray
    disturbance_torque: NDArray
    force_estimate: NDArray
    torque_estimate: NDArray
    termination_reason: str = ""
    applied_moment: NDArray | None = None  # (T, 3) [N m]
    extra: dict = field(default_factory=dict)


_RECORDED = ("time", "position", "velocity", "acceleration", "rotation", "reference_position",
             "reference_velocity", "reference_acceleration", "desired_rotation",
             "requested_thrust", "applied_thrust", "disturbance_force", "disturbance_torque",
             "force_estimate", "torque_estimate", "applied_moment")


def _stack_states(cores: list[QuadrotorBatch]) -> VehicleState:
    return VehicleState(*(np.concatenate([getattr(c.state, name) for c in cores]) for name in
                          ("position", "velocity", "rotation", "angular_velocity")))


def fly(controller: Controller, scenarios: Scenario | Sequence[Scenario],
        seed: int = 0) -> list[Flight]:
    """One episode of ``controller`` in each scenario, all flown together.

    Each scenario gets its own core (N = 1) and the controller sees them as one batch, so
    its numpy overhead is paid once per step for all of them. The scenarios must share the
    vehicle and dt. A flight's record stops at its scenario's end or its termination.
    """
    scenarios = [scenarios] if isinstance(scenarios, Scenario) else list(scenarios)
    vehicle, dt = scenarios[0].vehicle, scenarios[0].dt
    if any(s.vehicle != vehicle or s.dt != dt for s in scenarios):
        raise ValueError("fly() needs scenarios with one vehicle and one dt; got "
                         + ", ".join(f"{s.name} ({s.vehicle.name}, dt={s.dt})" for s in scenarios))
    cores = [QuadrotorBatch(s, 1) for s in scenarios]
    for core in cores:
        core.reset(np.zeros(1, dtype=np.intp), [seeding.np_random(seed)[0]])
    n = len(cores)
    controller.reset(n, vehicle, dt)
    steps = [s.steps for s in scenarios]
    rows: list[dict[str, list]] = [{key: [] for key in _RECORDED} for _ in cores]
    reasons = [""] * n
    flying = np.ones(n, dtype=bool)
    zeros = np.zeros((n, 3))
    gravity = np.array([0.0, 0.0, vehicle.gravity])
    for step in range(max(steps)):
        state = _stack_states(cores)
        refs = [core.reference for core in cores]
        reference = Reference(*(np.concatenate([getattr(r, f.name) for r in refs])
                                for f in fields(Reference)))
        thrust, moment = controller.compute(np.full(n, step * dt), state, reference)
        for i, core in enumerate(cores):
            core.step(core.action_from_command(thrust[i:i + 1], moment[i:i + 1]))
        applied_thrust = np.concatenate([core.applied.thrust for core in cores])
        applied_moment = np.concatenate([core.applied.moment for core in cores])
        controller.applied(state, applied_thrust, applied_moment)
        disturbance_force = np.concatenate([core.disturbance_force for core in cores])
        diagnostics = controller.diagnostics
        record = {
            "time": np.full(n, step * dt), "position": state.position,
            "velocity": state.velocity,
            "acceleration": (applied_thrust[:, None] * state.rotation[:, :, 2]
                             + disturbance_force) / vehicle.mass - gravity,
            "rotation": state.rotation, "reference_position": reference.position,
            "reference_velocity": reference.velocity,
            "reference_acceleration": reference.acceleration,
            "desired_rotation": diagnostics["desired_rotation"], "requested_thrust": thrust,
            "applied_thrust": applied_thrust, "applied_moment": applied_moment,
            "disturbance_force": disturbance_force,
            "disturbance_torque": np.concatenate([core.disturbance_torque for core in cores]),
            "force_estimate": diagnostics.get("force_estimate", zeros),
            "torque_estimate": diagnostics.get("torque_estimate", zeros),
        }
        for i in np.flatnonzero(flying):
            for key in _RECORDED:
                rows[i][key].append(np.array(record[key][i], copy=True))
            if cores[i].terminated[0] or step + 1 >= steps[i]:
                flying[i] = False
                reasons[i] = cores[i].termination_reason(0)
        if not flying.any():
            break
    return [Flight(scenario=s.name, controller=controller.name, dt=dt,
                   thrust_limit=vehicle.max_total_thrust,
                   **{key: np.array(values) for key, values in row.items()},
                   termination_reason=reason)
            for s, row, reason in zip(scenarios, rows, reasons, strict=True)]
