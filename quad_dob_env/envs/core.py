"""The batched environment core: N vehicles of one scenario, stepped together.

``QuadrotorEnv`` is its N = 1 view; a vector env runs the same object with N > 1, so the
physics, observation, reward and termination are written once.

Every vehicle's time is ``step_count * dt``, so whatever depends on time alone (the
reference and the non-random disturbances) is tabulated once on that grid (a
``TrajectoryFamily``'s members stacked, each vehicle reading its member's block at
``reference_row``), and one compiled call per step does the rest for the whole batch:
action -> command -> actuation -> integration -> observation, reward, termination.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.compile_notice import announces_compiling
from quad_dob_env.disturbances import split_by_randomness
from quad_dob_env.dynamics import (
    NO_GROUND_EFFECT,
    Actuator,
    AppliedCommand,
    BodyArrays,
    Forcing,
    VehicleState,
    physics_arrays,
)
from quad_dob_env.envs.actions import ActionMap
from quad_dob_env.envs.info import info_arrays
from quad_dob_env.envs.limits import (
    EpisodeLimits,
    RewardWeights,
    check_vehicle_memory,
    episode_steps,
)
from quad_dob_env.envs.observation import env_entries, observation_size
from quad_dob_env.envs.step_kernels import (
    ActionMapArrays,
    Episode,
    EpisodeStart,
    StartArguments,
    StepArguments,
    StepOutputs,
    kernel_tuples,
    measured_finish_kernel,
    settled_command_kernel,
    start_kernel,
    step_kernel,
)
from quad_dob_env.envs.termination import (
    INVALID_ACTION,
    TIME_LIMIT,
    TerminationCode,
)
from quad_dob_env.envs.vehicle_loop import VehicleLoop
from quad_dob_env.flatness import flat_attitude
from quad_dob_env.memory import check_memory
from quad_dob_env.scenario import REFERENCE_ROW_BYTES
from quad_dob_env.scenarios import Scenario
from quad_dob_env.sensing import Measurement, SensingStage
from quad_dob_env.so3 import exp as so3_exp
from quad_dob_env.threads import run_over_batch
from quad_dob_env.trajectories import REFERENCE_FIELDS, Reference, TrajectoryFamily

# --- the core ----------------------------------------------------------------------------

class QuadrotorBatch:
    """N vehicles flying ``scenario`` under normalised actions in [-1, 1]^4."""

    def __init__(self, scenario: Scenario, num_vehicles: int = 1,
                 action_mode: str = "thrust_moments", rotation_representation: str = "matrix",
                 limits: EpisodeLimits | None = None, reward: RewardWeights | None = None) -> None:
        entries = env_entries(rotation_representation)  # refuses an unknown one, named
        if not isinstance(num_vehicles, (int, np.integer)) or num_vehicles < 1:
            raise ValueError(f"num_vehicles must be an integer >= 1, got {num_vehicles!r}")
        check_vehicle_memory(int(num_vehicles))
        self.scenario = scenario
        self.n = n = int(num_vehicles)
        self.rotation_representation = rotation_representation
        self.limits = limits or EpisodeLimits()
        self.reward_weights = reward or RewardWeights()
        self.vehicle = scenario.vehicle
        # the airframe the physics flies: the vehicle with the loop's own drag where it has
        # one (v4's fitted), the controllers' model keeping the vehicle's
        self.airframe = scenario.loop.airframe(self.vehicle)
        self.actuator = Actuator(self.vehicle, scenario.actuation)
        self.action_map = ActionMap(self.vehicle, self.actuator, action_mode)
        self.observation_size = observation_size(entries)
        self.thrust_law = (NO_GROUND_EFFECT if scenario.ground_effect is None
                           else scenario.ground_effect.law(self.vehicle, scenario.floor_height))
        self._law = tuple(float(value) for value in self.thrust_law)
        samples = 2 * scenario.integration_intervals + 1
        self._sample_offsets = np.arange(samples) * (scenario.dt / (samples - 1))
        # tabulate what depends on time alone; keep random parts to evaluate each step
        self._timed_parts, self.random_disturbance = split_by_randomness(
            scenario.disturbance, n, scenario.dt)
        trajectory = scenario.trajectory
        self._members = (trajectory.members if isinstance(trajectory, TrajectoryFamily)
                         else (trajectory,))
        # which member each vehicle flies, and its row in the stacked reference table
        self.reference_member = np.zeros(n, dtype=np.int64)
        self.reference_start = np.zeros(n, dtype=np.int64)  # its start's row in the member
        self.reference_row = np.zeros(n, np.int64)
        self.step_count = np.zeros(n, np.int64)
        self._start_steps = scenario.start_spread_steps
        self._tabulate(scenario.table_rows)
        # an episode is truncated after this many steps (``set_time_limit``)
        self.episode_steps = scenario.steps
        self.state = VehicleState.at_rest(n)
        self._most_steps = 0  # at least step_count.max(), kept without a pass over N
        self._actions = np.zeros((n, 4))  # a step's actions, as the kernel takes them
        self._kernel_tuples: tuple[tuple, tuple] = ((), ())  # see _kernel_arguments
        self._kernel_tables = None
        self._reference_now: Reference | None = None
        self.termination_code = np.zeros(n, dtype=np.int8)  # a TerminationCode per vehicle
        self.obs = np.zeros((n, self.observation_size), dtype=np.float32)
        self.rewards = np.zeros(n)
        self.applied = AppliedCommand(np.zeros(n), np.zeros((n, 3)), np.zeros((n, 4)),
                                      np.zeros(n, dtype=np.bool_))
        # what the autopilot commanded over the step (its mixer's output, in its own thrust
        # model's newtons; ``saturated`` is the step's, shared with ``applied``)
        self.commanded = AppliedCommand(np.zeros(n), np.zeros((n, 3)), np.zeros((n, 4)),
                                        self.applied.saturated)
        self.disturbance_force = np.zeros((n, 3))
        self.disturbance_torque = np.zeros((n, 3))
        self.wind_velocity = np.zeros((n, 3))
        self._own = tuple(np.zeros((n, samples, 3)) for _ in range(3))  # force, torque, wind
        # per-vehicle physics (mass, inertia, inverse, drag), so vehicles can differ
        self._nominal = physics_arrays(self.airframe, 1, scenario.loop.drag,
                                       scenario.loop.rotor_aerodynamics)
        body = physics_arrays(self.airframe, n, scenario.loop.drag,
                              scenario.loop.rotor_aerodynamics)
        self.mass, self.inertia, self.inertia_inverse, self.drag = (
            body.mass, body.inertia, body.inertia_inverse, body.drag)
        self.sampled: list[dict[str, float]] = [{} for _ in range(n)]
        self.actuator_state = np.zeros((n, 4))
        self._actuator = self.actuator.kernel_record(self.actuator_state)
        self._limits = tuple(self.limits.kernel_limits(scenario.floor_height))
        self._rotation_mode = 0 if rotation_representation == "matrix" else 1
        self.sensing = SensingStage(
            scenario.loop.sensing, scenario.loop.extra_latency, self.state,
            (self.applied.thrust, self.disturbance_force, self.mass, self.applied.rotor_thrusts),
            self.vehicle, scenario.dt,
            hover=(self.vehicle.hover_thrust,
                   self.actuator.to_rotors @ self.actuator.hover_output()),
            vibration=scenario.loop.imu_vibration or (0.0, 0.0),
            ticks=scenario.inner_ticks if scenario.loop.pose_latency_on_ticks else 1,
            unmodelled_pose_latency=scenario.loop.unmodelled_pose_latency,
            vibration_scale=scenario.loop.imu_vibration_scale,
            tones=scenario.loop.imu_vibration_tones)
        # the kernels write the true state's observation here; a policy reads ``obs`` (the
        # same array for the identity, else rebuilt from the measurement)
        self._true_obs = self.obs if self.sensing.identity else np.zeros_like(self.obs)
        self._all = np.arange(n)
        # what a reset writes, looked up once: a reset of a few vehicles is mostly fixed cost
        self._start = tuple(np.asarray(value, dtype=float) for value in (
            scenario.initial_position, scenario.initial_velocity,
            scenario.initial_angular_velocity))
        self._initial_rotation = scenario.initial_rotation_matrix()
        m = self.sensing.measurement
        self.loop = VehicleLoop(scenario, self.actuator, n, action_mode,
                                (not self.sensing.identity, m.rotation, m.angular_velocity),
                                (self.sensing.pose_tick, *self.sensing.pose_state))
        self._hover_output = self.loop.hover_output(self.actuator.hover_output())
        self.attitude_loop = None  # flies a controller's attitude law at the inner rate

    def _tabulate(self, rows: int) -> None:
        """Reference and time-only disturbances on the grid ``t = step * dt``, ``rows`` steps;
        a family's members stacked, ``rows`` each, member k's block from row k * rows."""
        dt = self.scenario.dt
        check_memory(rows * len(self._members) * REFERENCE_ROW_BYTES,
                     f"the reference table of scenario {self.scenario.name!r} grown to "
                     f"{rows:,} rows (an episode stepped far past its end without a reset)",
                     "reset the env when an episode ends")
        times = np.arange(rows) * dt
        self._reference_table = np.ascontiguousarray(
            np.concatenate([member.table(times) for member in self._members]))
        self._member_rows = rows
        self.reference_row[:] = (self.reference_member * rows + self.reference_start
                                 + self.step_count)
        grid = times[:, None] + self._sample_offsets
        channels = [np.zeros((*grid.shape, 3)) for _ in range(3)]  # force, torque, wind
        for part in self._timed_parts:
            for total, channel in zip(channels, part.evaluate(grid), strict=True):
                total += channel
        self._tables = tuple(channels)

    # --- time and reference ---------------------------------------------------------------
    @property
    def time(self) -> NDArray[np.float64]:
        """Per-vehicle time [s]; a multiple of dt, so it never drifts."""
        return self.step_count * self.scenario.dt

    @property
    def reference_table(self) -> NDArray[np.float64]:
        """The reference on the control grid, (members x rows, 8, 3) in ``Reference``'s field
        order; vehicle i reads row ``reference_row[i]``, time ``step_count[i] dt`` of its
        member. It is replaced (not grown in place) when flown past its end."""
        return self._reference_table

    def member_reference(self, index: int, steps: int) -> NDArray[np.float64]:
        """Vehicle ``index``'s reference over its first ``steps`` rows, (steps, 8, 3)."""
        first = int(self.reference_member[index]) * self._member_rows
        return self._reference_table[first:first + min(steps, self._member_rows)]

    def member_paths(self, steps: int) -> NDArray[np.float64]:
        """Every member's reference position over its first ``steps`` rows, (K, steps, 3)."""
        return self._reference_table.reshape(len(self._members), -1, 8, 3)[:, :steps, 0]

    @property
    def reference(self) -> Reference:
        """The reference at each vehicle's current time, (N, 3) per field (read-only views,
        gathered once per step)."""
        if self._reference_now is None:
            rows = np.take(self._reference_table, self.reference_row, axis=0)  # faster than []
            rows.flags.writeable = False
            self._reference_now = Reference(*(rows[:, j] for j in range(len(REFERENCE_FIELDS))))
        return self._reference_now

    # --- reset ----------------------------------------------------------------------------
    @announces_compiling
    def reset(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        """Start a new episode for vehicles ``indices``, drawing from ``rngs`` (one each)."""
        indices = np.asarray(indices, dtype=np.intp)
        if len(rngs) != len(indices):
            raise ValueError(f"reset needs one generator per vehicle: {len(indices)} vehicles, "
                             f"{len(rngs)} generators")
        sc = self.scenario
        count = len(indices)
        members = np.zeros(count, dtype=np.int64)  # which reference of a family
        starts = np.zeros(count, dtype=np.int64)  # from which of its rows
        draws = np.empty((count, 6))  # position offset, attitude offset (rotation vector)
        scales = np.ones((count, 3))  # mass, inertia, drag
        randomization = sc.randomization
        for j, rng in enumerate(rngs):
            # fixed draw order per vehicle: a family's member and the start's row on it (the
            # start is relative to them), position, attitude (one call, the same numbers as
            # two), randomisation, then the disturbance; the sensors' keys come from a stream
            # spawned off it, which draws nothing from it
            if len(self._members) > 1:
                members[j] = rng.integers(len(self._members))
            if self._start_steps:
                starts[j] = rng.integers(self._start_steps + 1)
            draws[j] = rng.uniform(-1.0, 1.0, 6)
            if randomization is not None:
                r = randomization
                scales[j] = [rng.uniform(*r.mass), rng.uniform(*r.inertia), rng.uniform(*r.drag)]
            # one child a reset (the sensors read it, the rotors a grandchild of it); the
            # sensors start last, so the stream their ranges spawn follows the rotors' own
            child = (rng.spawn(1)[0] if not self.sensing.identity or self.loop.needs_streams
                     else None)
            self.loop.start(int(indices[j]), child)
            self.sensing.start(int(indices[j]), child)
            if self.loop.tolerance is not None:  # the controllers keep the nominal model
                scales[j, :2] *= self.loop.truth_scales(int(indices[j]))
        offsets = np.zeros((count, 6))  # position, velocity
        offsets[:, :3] = draws[:, :3] * sc.initial_position_noise
        rows = members * self._member_rows + starts
        self.reference_member[indices] = members
        self.reference_start[indices] = starts
        self.reference_row[indices] = rows
        first = self._initial_rotation
        if sc.starts_on_reference:  # on its reference where it starts:
            firsts = self._reference_table[rows]  # position, velocity, the attitude flying it
            offsets += firsts[:, :2].reshape(-1, 6) - np.concatenate(self._start[:2])
            first = flat_attitude(Reference(*firsts.transpose(1, 0, 2)), self.vehicle.mass,
                                  self.vehicle.gravity).rotation
        rotations = first @ so3_exp(draws[:, 3:] * sc.initial_attitude_noise)
        start_kernel(indices, offsets, rotations, scales, *self._kernel_arguments()[1])
        self.wind_velocity[indices] = 0.0  # as the disturbance: no step flown through air yet
        random = self.random_disturbance
        if random is not None:
            random.resample(indices, rngs)
        for j, index in enumerate(indices):
            self.sampled[index] = {
                **({} if randomization is None else {
                    "mass": float(self.mass[index]), "inertia_scale": float(scales[j, 1]),
                    "drag_scale": float(scales[j, 2])}),
                **({} if random is None else random.sampled_parameters(index)),
                **self.loop.sampled(index), **self.sensing.sampled(index)}
        self._reference_now = None
        self._measure(indices, reset=True)

    # --- step -----------------------------------------------------------------------------
    @announces_compiling
    def step(self, actions: NDArray[np.float64]) -> None:
        """Fly one control step from finite normalised actions (N, 4); values beyond
        [-1, 1] are clipped (the reward's effort term sees the clipped values).

        Updates ``state``, ``obs``, ``rewards``, ``termination_code``, ``applied`` and the
        true ``disturbance_force`` / ``disturbance_torque``.
        """
        self.prepare_step()
        # the stage's own record: its rates are current under any sensing, where
        # ``measurement`` would first refresh the ideal IMU's readings, a compiled call
        self._actions[...] = (actions if self.loop.rates else self.action_map.flown(
            actions, self.sensing.measurement.angular_velocity,
            self.loop.told_inertia(self.inertia)))
        if self.attitude_loop is not None:  # a controller's attitude law at the inner rate
            self.attitude_loop.step(self._actions)
        else:
            run_over_batch(step_kernel, self.n, self._actions, *self._kernel_arguments()[0])
        self.finish_step()

    def prepare_step(self) -> None:
        """Before the compiled pass of a step: the tables long enough, and the random
        disturbances sampled over the step."""
        self._reference_now = None
        rows = self._member_rows  # each member's block (a family stacks them)
        ahead = self._start_steps + 1  # the most rows a reference may be ahead of time
        if self._most_steps + ahead >= rows:  # maybe flown past the scenario's end
            self._most_steps = int(self.step_count.max())
            if self._most_steps + ahead >= rows:
                self._tabulate(2 * rows)
        self._most_steps += 1  # every vehicle's count grows by one; a reset only lowers it
        random = self.random_disturbance
        if random is not None:
            for own, written in zip(self._own, random.channels, strict=True):
                if written:
                    own.fill(0.0)
            times = self.time[:, None] + self._sample_offsets if random.uses_time else None
            if random.follows_vehicle:  # a state-dependent model reads the true state first
                random.follow(self.state.position, self.state.velocity, self.mass)
            random.add_to(times, *self._own)

    def _kernel_arguments(self) -> tuple[tuple, tuple]:
        """The step and start kernels' records, built once per reference table (the other
        arrays never change) and kept as plain tuples, which numba types fast."""
        if self._kernel_tables is not self._reference_table:
            step = self.step_arguments()
            start = StartArguments(
                start=EpisodeStart(*self._start, hover=self._hover_output),
                nominal=self._nominal,
                state=step.state, body=step.body, actuator=step.actuator,
                episode=step.episode, outputs=step.outputs)
            self._kernel_tuples = (kernel_tuples(step), kernel_tuples(start))
            self._kernel_tables = self._reference_table
        return self._kernel_tuples

    def step_arguments(self) -> StepArguments:
        """What ``step_kernel`` takes after the slice and the actions."""
        sc, applied = self.scenario, self.applied
        weights = self.reward_weights
        return StepArguments(
            action_map=ActionMapArrays(*self.action_map.forward),
            state=self.state.arrays(),
            body=BodyArrays(mass=self.mass, gravity=float(self.vehicle.gravity),
                            inertia=self.inertia, inertia_inverse=self.inertia_inverse,
                            drag=self.drag),
            actuator=self._actuator, rotors=self.loop.model, draws=self.loop.draws,
            inner=self.loop.inner,
            forcing=Forcing(*self._tables, *self._own),
            episode=Episode(
                step_count=self.step_count, reference_row=self.reference_row,
                reference=self._reference_table, dt=sc.dt, substeps=sc.substeps,
                thrust_law=self._law, limits=self._limits,
                position_scale=float(weights.position_scale),
                effort_weight=float(weights.effort_weight),
                rotation_mode=self._rotation_mode),
            outputs=StepOutputs(
                obs=self._true_obs, reward=self.rewards, code=self.termination_code,
                applied_thrust=applied.thrust, applied_moment=applied.moment,
                rotor_thrusts=applied.rotor_thrusts, saturated=applied.saturated,
                commanded_thrust=self.commanded.thrust,
                commanded_moment=self.commanded.moment,
                commanded_rotor_thrusts=self.commanded.rotor_thrusts,
                disturbance_force=self.disturbance_force,
                disturbance_torque=self.disturbance_torque, wind_velocity=self.wind_velocity))

    def finish_step(self) -> None:
        """After the compiled pass: the sensors, the estimate, and the policy's
        observation of it."""
        self._measure(self._all, reset=False)

    def finish_arguments(self, indices: NDArray[np.intp] | None = None,
                         reset: bool = False) -> tuple:
        """What ``measured_finish_kernel`` takes after its slice, for vehicles ``indices``
        (default: all) after a step or at their ``reset``: a compiled pass that calls it
        for its slice replaces ``finish_step``. Sensing other than the identity only (it
        measures nothing there)."""
        m = self.sensing.measurement
        observe = (m.position, m.velocity, m.rotation, m.angular_velocity,
                   self._reference_table, self.reference_row, self._rotation_mode, self.obs)
        return (self._all if indices is None else indices, self.step_count, reset,
                tuple(self.sensing.measure_arguments), observe)

    def _measure(self, indices: NDArray[np.intp], reset: bool) -> None:
        sensing = self.sensing
        if sensing.identity:
            sensing.measure(indices, self.step_count, reset)
            return
        if reset:
            sensing.start_estimates(indices)
        run_over_batch(measured_finish_kernel, len(indices),
                       *self.finish_arguments(indices, reset))

    @property
    def estimator_wrench(self) -> AppliedCommand:
        """What the estimators are told was applied over the last step
        (``LoopOptions.estimator_wrench``): ``applied`` (the rotors' output, v1-v3) or
        ``commanded`` (the autopilot's own command). Its arrays are the core's own."""
        if self.scenario.loop.estimator_wrench == "commanded":
            return self.commanded
        return self.applied

    def settled_command(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The thrust (N,) [N] and moments (N, 3) [N m] the nominal model gives once the
        motors have settled on the autopilot's command of the last step, through the
        battery and the throttle map (``ticks.settled_wrench``): the thrust path's own
        error, ``settled - commanded``, without the motors' lag. The truth, for the loop's
        floor; no real stack has it."""
        thrust, moment = np.empty(self.n), np.empty((self.n, 3))
        run_over_batch(settled_command_kernel, self.n, *self._kernel_arguments()[0], thrust,
                       moment)
        return thrust, moment

    @property
    def measurement(self) -> Measurement:
        """What every policy reads (``quad_dob_env.sensing.Measurement``): the estimate and
        the raw readings. With ideal sensing its state fields are the true state's own
        arrays."""
        if self.sensing.identity:
            self.sensing.refresh_ideal()
        return self.sensing.measurement

    def info_arrays(self) -> dict[str, NDArray | dict[str, NDArray]]:
        """Every vehicle's ``info`` numbers now (``envs.info.info_arrays``)."""
        return info_arrays(self)

    def end_for_invalid_actions(self, indices: NDArray[np.intp]) -> None:
        """End the episodes of vehicles whose action was NaN or infinite (flown at the
        hover command) with reason ``invalid_action``."""
        self.termination_code[indices] = INVALID_ACTION

    def set_time_limit(self, max_episode_steps: int | None) -> None:
        """Truncate episodes after ``max_episode_steps`` steps (``make_vec(...,
        max_episode_steps=N)``) or at the scenario's end if sooner; None: the scenario's."""
        self.episode_steps = episode_steps(self.scenario.steps, max_episode_steps)

    @property
    def terminated(self) -> NDArray[np.bool_]:
        return self.termination_code > 0

    @property
    def truncated(self) -> NDArray[np.bool_]:
        return (self.step_count >= self.episode_steps) & ~self.terminated

    def termination_reason(self, index: int) -> str:
        """``info["termination_reason"]`` for a vehicle whose episode ended, else ''."""
        code = TerminationCode(int(self.termination_code[index]))
        if code:
            return code.reason
        return TIME_LIMIT if self.step_count[index] >= self.episode_steps else ""
