"""Fly a controller through a scenario and keep everything that happened.

The same records feed ``quad-dob paper``'s tables and figures and, later, evaluation, so
every report computes its metrics from one kind of data.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, fields

import numpy as np
from gymnasium.utils import seeding
from numpy.typing import NDArray

from quad_dob_baselines.base import Controller
from quad_dob_composition.attitude_loop import AttitudeLoop
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.memory import check_memory, format_bytes
from quad_dob_env.params import VehicleParams
from quad_dob_env.scenarios import Scenario
from quad_dob_env.sensing import Measurement
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
    # the four rotor thrusts the command asked for, before the actuators' limits [N]: the
    # allocation's inverse of the requested thrust and moment (T, 4)
    requested_rotor_thrusts: NDArray
    applied_thrust: NDArray
    disturbance_force: NDArray
    disturbance_torque: NDArray
    force_estimate: NDArray
    torque_estimate: NDArray
    termination_reason: str = ""
    applied_moment: NDArray | None = None  # (T, 3) [N m]
    # what the controller read (the true state with ideal sensing)
    estimated_position: NDArray | None = None
    estimated_velocity: NDArray | None = None
    estimated_rotation: NDArray | None = None
    extra: dict = field(default_factory=dict)
    settle_time: float = 2.0  # [s] the scenario's: the settled scores skip t < this
    actuation: str = "rotors"  # the scenario's: "wrench" flies no rotor command


# what FlightRecorder keeps each step, field by field: values per vehicle and step
RECORDED_WIDTHS = {"time": 1, "position": 3, "velocity": 3, "acceleration": 3, "rotation": 9,
                   "reference_position": 3, "reference_velocity": 3,
                   "reference_acceleration": 3, "desired_rotation": 9, "requested_thrust": 1,
                   "requested_rotor_thrusts": 4, "applied_thrust": 1, "disturbance_force": 3,
                   "disturbance_torque": 3,
                   "force_estimate": 3, "torque_estimate": 3, "applied_moment": 3,
                   "estimated_position": 3, "estimated_velocity": 3, "estimated_rotation": 9}
_RECORDED = tuple(RECORDED_WIDTHS)
# The bytes one vehicle's step costs: each field is its own small array in a list (an
# ndarray's header, 112 B measured with tracemalloc, rounded up; the list's slot), and
# flights() stacks a copy of the data before the lists go: 3,888 B.
ARRAY_BYTES = 128
RECORD_BYTES_PER_STEP = sum(ARRAY_BYTES + 8 + 2 * 8 * width
                            for width in RECORDED_WIDTHS.values())


# control steps a warm-up flies: enough for every kernel of a loop to run, and so compile
# on a first run, before the flights that count
WARM_UP_STEPS = 5


def warm_up_copy(scenario: Scenario) -> Scenario:
    """``scenario`` cut to ``WARM_UP_STEPS`` control steps: flown first, it compiles (or
    loads from numba's cache) every kernel the whole flight needs, with the same types."""
    return scenario.with_changes(duration=WARM_UP_STEPS * scenario.dt)


def check_flight_memory(flights: int, steps: int, what: str,
                        change: str = "fly fewer seeds at once (--seeds)") -> None:
    """Refuse (``quad_dob_env.memory.check_memory``) flights whose records would pass the
    memory budget, before any env, list or array is built."""
    check_memory(int(flights) * int(steps) * RECORD_BYTES_PER_STEP,
                 f"{what}: the records of {int(flights):,} flights of {int(steps):,} steps "
                 f"({format_bytes(RECORD_BYTES_PER_STEP)} a step)", change)


class FlightRecorder:
    """Records of N vehicles, step by step, each stopped at its episode's end (``fly`` and
    ``quad_dob_training.policies.fly_policy`` both keep theirs here)."""

    def __init__(self, n: int, vehicle: VehicleParams) -> None:
        self.rows: list[dict[str, list]] = [{key: [] for key in _RECORDED} for _ in range(n)]
        self.reasons = [""] * n
        self.flying = np.ones(n, dtype=bool)
        self.vehicle = vehicle
        self._gravity = np.array([0.0, 0.0, vehicle.gravity])

    def add(self, state: VehicleState, ended: NDArray[np.bool_], reason: Callable[[int], str],
            requested_moment: NDArray, **record: NDArray) -> bool:
        """Keep one step of the vehicles still flying (``record``: the other ``_RECORDED``
        fields, (N, ...) each; the ``estimated_`` ones default to the true state;
        ``requested_moment`` with ``requested_thrust`` gives the rotor command);
        ``ended`` marks whose episode this step ended, and ``reason(i)`` says why. Returns
        whether any vehicle still flies."""
        for name in ("position", "velocity", "rotation"):
            record.setdefault(f"estimated_{name}", getattr(state, name))
        # the true acceleration, from the applied thrust and the disturbance
        record["acceleration"] = (record["applied_thrust"][:, None] * state.rotation[:, :, 2]
                                  + record["disturbance_force"]) / self.vehicle.mass \
            - self._gravity
        record.update(position=state.position, velocity=state.velocity,
                      rotation=state.rotation)
        wrench = np.column_stack([record["requested_thrust"], requested_moment])
        record["requested_rotor_thrusts"] = wrench @ self.vehicle.mixer_matrix.T
        for i in np.flatnonzero(self.flying):
            for key in _RECORDED:
                self.rows[i][key].append(np.array(record[key][i], copy=True))
            if ended[i]:
                self.flying[i] = False
                self.reasons[i] = reason(i)
        return bool(self.flying.any())

    def flights(self, scenarios: Sequence[Scenario], controller: str, dt: float
                ) -> list[Flight]:
        return [Flight(scenario=scenario.name, controller=controller, dt=dt,
                       thrust_limit=self.vehicle.max_total_thrust,
                       **{key: np.array(values) for key, values in row.items()},
                       termination_reason=reason, settle_time=scenario.settle_time,
                       actuation=scenario.actuation)
                for scenario, row, reason in zip(scenarios, self.rows, self.reasons,
                                                 strict=True)]


def _stack_states(cores: list[QuadrotorBatch]) -> VehicleState:
    return VehicleState(*(np.concatenate([getattr(c.state, name) for c in cores]) for name in
                          ("position", "velocity", "rotation", "angular_velocity")))


def _stack_measurements(cores: list[QuadrotorBatch]) -> Measurement:
    """What the controller reads: every core's measurement, stacked."""
    measured = [core.measurement for core in cores]
    return Measurement(*(np.concatenate([getattr(m, name) for m in measured]) for name in (
        "position", "velocity", "rotation", "angular_velocity", "gyroscope", "accelerometer",
        "rotor_speeds")))


def fly(controller: Controller, scenarios: Scenario | Sequence[Scenario],
        seed: int = 0) -> list[Flight]:
    """One episode of ``controller`` in each scenario, all flown together.

    Each scenario gets its own core (N = 1) and the controller sees them as one batch (one
    per actuation), so its numpy overhead is paid once per step for all of them. The
    scenarios must share the vehicle and dt. A flight's record stops at its scenario's end
    or its termination.
    """
    scenarios = [scenarios] if isinstance(scenarios, Scenario) else list(scenarios)
    vehicle, dt = scenarios[0].vehicle, scenarios[0].dt
    if any(s.vehicle != vehicle or s.dt != dt for s in scenarios):
        raise ValueError("fly() needs scenarios with one vehicle and one dt; got "
                         + ", ".join(f"{s.name} ({s.vehicle.name}, dt={s.dt})" for s in scenarios))
    check_flight_memory(len(scenarios), max(s.steps for s in scenarios),
                        f"flying {len(scenarios)} scenario(s)", "fly fewer or shorter scenarios")
    actuations = list(dict.fromkeys(s.actuation for s in scenarios))
    if len(actuations) > 1:
        # a controller that models its actuators (the PID's anti-windup) flies one batch
        # per actuation
        flights: list = [None] * len(scenarios)
        for actuation in actuations:
            group = [i for i, s in enumerate(scenarios) if s.actuation == actuation]
            for i, flight in zip(group, fly(controller, [scenarios[i] for i in group], seed),
                                 strict=True):
                flights[i] = flight
        return flights
    actuation = actuations[0]
    cores = [QuadrotorBatch(s, 1) for s in scenarios]
    if len({s.inner_ticks if s.loop.inner_rate is not None else None for s in scenarios}) > 1:
        raise ValueError("fly() needs scenarios with one inner loop (or none); got "
                         + ", ".join(f"{s.name} (inner_rate={s.loop.inner_rate})"
                                     for s in scenarios))
    for i, core in enumerate(cores):
        core.reset(np.zeros(1, dtype=np.intp), [seeding.np_random(seed)[0]])
        # core i is row i of the controller's batch
        AttitudeLoop.install(core, controller, slice(i, i + 1))
    n = len(cores)
    controller.reset(n, vehicle, dt, actuation=actuation)
    steps = [s.steps for s in scenarios]
    recorder = FlightRecorder(n, vehicle)
    zeros = np.zeros((n, 3))
    for step in range(max(steps)):
        state, measured = _stack_states(cores), _stack_measurements(cores)
        refs = [core.reference for core in cores]
        reference = Reference(*(np.concatenate([getattr(r, f.name) for r in refs])
                                for f in fields(Reference)))
        thrust, moment = controller.compute(np.full(n, step * dt), measured, reference)
        for i, core in enumerate(cores):
            core.step(core.action_map.to_actions(thrust[i:i + 1], moment[i:i + 1]))
        # what the estimators are told was applied (LoopOptions.estimator_wrench)
        applied_thrust = np.concatenate([core.estimator_wrench.thrust for core in cores])
        applied_moment = np.concatenate([core.estimator_wrench.moment for core in cores])
        controller.applied(measured, applied_thrust, applied_moment)
        diagnostics = controller.diagnostics
        ended = np.array([core.terminated[0] or step + 1 >= steps[i]
                          for i, core in enumerate(cores)])
        if not recorder.add(
                state, ended, lambda i: cores[i].termination_reason(0),
                time=np.full(n, step * dt), reference_position=reference.position,
                reference_velocity=reference.velocity,
                reference_acceleration=reference.acceleration,
                desired_rotation=diagnostics["desired_rotation"], requested_thrust=thrust,
                requested_moment=moment, applied_thrust=applied_thrust,
                applied_moment=applied_moment,
                disturbance_force=np.concatenate([core.disturbance_force for core in cores]),
                disturbance_torque=np.concatenate([core.disturbance_torque for core in cores]),
                force_estimate=diagnostics.get("force_estimate", zeros),
                torque_estimate=diagnostics.get("torque_estimate", zeros),
                estimated_position=measured.position, estimated_velocity=measured.velocity,
                estimated_rotation=measured.rotation):
            break
    return recorder.flights(scenarios, controller.name, dt)
