"""The geometric (+NDOB) base, the residual and the vehicle's loop in one compiled pass.

``ResidualCommand`` drives any controller through ``compute`` and ``applied``: a handful of
batch calls and array operations per step, ~250 µs of Python whatever N is, which at
N = 256 cost more than the vehicles themselves. For the geometric controller it is handed
this pass instead (``quad_dob_composition.bases.fused_pass_for``): one call per step, cut
into one slice per core, runs for each vehicle, in v1's loop (ideal sensing, no inner loop)

    residual -> command -> physics step -> observer update -> observer estimate ->
    geometric law for the next step -> extra observation and reward,

and in a loop with sensors and an inner loop (Benchmark v2, v3)

    residual -> command -> at each tick: the attitude law on the inner-rate estimate + the
    residual -> mixer, motors, physics -> readings -> estimator -> measurement and
    observation -> observer update and reward -> observer estimate -> geometric law's outer
    part for the next step -> extra observation.

It calls the same per-vehicle functions as the separate stages
(``quad_dob_env.envs.step_kernels``, ``quad_dob_env.sensing`` and
``quad_dob_baselines.geometric_kernels``), so there is still one source for every equation;
a test holds it to the separate stages to 1e-12 through autoresets, in v1, v2 and v3. It
reads the controller, the observer and the core through their public faces only
(``position_gains``, ``kernel_state()``, ``inner_gains``, ``inner_law()``,
``reference_table``, ``step_arguments()``, ``finish_arguments()``). From 256 vehicles its
slices run on threads at once (``quad_dob_env.threads``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_baselines.geometric_kernels import (
    GeometricOutputs,
    geometric_law,
    geometric_law_of,
    observer_advance,
    observer_estimate,
    reference_at,
    store_geometric,
)
from quad_dob_composition.attitude_loop import attitude_loop_kernel
from quad_dob_env.dynamics import load_vehicle
from quad_dob_env.envs.step_kernels import kernel_tuples, measured_finish_kernel, step_kernel
from quad_dob_env.residual.residual_kernels import (
    residual_addition_kernel,
    residual_command_kernel,
    residual_observation,
    residual_reward_kernel,
    store_residual_observation,
)
from quad_dob_env.so3 import matrix_entries, store_vector, vector_at
from quad_dob_env.threads import run_over_batch

if TYPE_CHECKING:
    from quad_dob_baselines.geometric import GeometricController
    from quad_dob_env.residual import ResidualCommand

class PlanArguments(NamedTuple):
    """What ``plan_kernel`` reads and writes for the whole batch: built by keyword and read
    by field, so a misplaced array cannot pass for another."""

    position: NDArray  # the state now, (N, 3) and (N, 3, 3)
    velocity: NDArray
    rotation: NDArray
    angular_velocity: NDArray
    reference: NDArray  # the core's reference table (rows, 8, 3)
    reference_row: NDArray  # (N,) each vehicle's row in it
    mass: float  # the geometric law's constants
    gravity: float
    inertia: NDArray  # (3, 3)
    gains: NDArray  # (4, 3): kx, kv [N/m, N s/m], kR, kΩ
    has_observer: bool  # the observer's discrete gains and state (ObserverKernelState)
    observer_gain: float
    observer_rotational_gain: NDArray
    z_force: NDArray
    z_torque: NDArray
    fresh: NDArray
    force_estimate: NDArray  # what the plan writes: estimates, base command, diagnostics
    torque_estimate: NDArray
    thrust: NDArray
    moment: NDArray
    desired_force: NDArray
    desired_rotation: NDArray
    desired_rate: NDArray
    desired_acceleration: NDArray
    attitude_error: NDArray
    rate_error: NDArray
    estimate_scale: NDArray  # the extra observation's scales and the inverse action map
    inverse: tuple
    base_action: NDArray  # scratch rows and the extra observation (N, 16)
    body_errors: NDArray
    extra: NDArray


class UpdateArguments(NamedTuple):
    """What the observer's update and the reward need in ``fused_residual_kernel``."""

    velocity_before: NDArray  # the state before the step, (N, 3)
    body_z_before: NDArray
    rate_before: NDArray
    alpha: float  # the observer's discrete rates (ObserverKernelState)
    rotational_alpha: NDArray
    clipped: NDArray  # the residual clipped to [-1, 1]
    core_rewards: NDArray
    effort_weight: float
    rate_weight: float
    previous: NDArray  # the residual of the step before, (N, 4)
    rewards: NDArray
    applied_thrust: NDArray
    applied_moment: NDArray
    # the observer's zΩ advances here, at the control rate; False with an inner loop, whose
    # attitude law advances it every tick
    advance_torque: bool


@njit(cache=True)
def plan_kernel(indices, plan):
    """Each vehicle of ``indices``: its observer estimate, base command and extra
    observation for the coming step, from its state now (``plan``: a ``PlanArguments`` as a
    plain tuple)."""
    plan = PlanArguments(*plan)
    law = geometric_law_of(plan.mass, plan.gravity, plan.inertia, plan.gains)
    km = matrix_entries(plan.observer_rotational_gain)  # a 9-tuple, as the equations take it
    # every array taken out once, before the vehicles, and read and written here in
    # straight lines; the equations take numbers: an array handed to an inlined function
    # with a branch or a loop counts a reference in and out at every call
    position, velocity = plan.position, plan.velocity
    rotation, angular_velocity = plan.rotation, plan.angular_velocity
    force_estimate, torque_estimate = plan.force_estimate, plan.torque_estimate
    has_observer, observer_gain = plan.has_observer, plan.observer_gain
    z_force, z_torque, fresh = plan.z_force, plan.z_torque, plan.fresh
    reference, reference_row = plan.reference, plan.reference_row
    outputs = GeometricOutputs(plan.thrust, plan.moment, plan.desired_force,
                               plan.desired_rotation, plan.desired_rate,
                               plan.desired_acceleration, plan.attitude_error, plan.rate_error)
    base_action, body_errors, extra = plan.base_action, plan.body_errors, plan.extra
    es = plan.estimate_scale
    scale = (es[0], es[1], es[2], es[3], es[4], es[5])
    inverse = plan.inverse
    for i in indices:
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        d_x, d_w = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        if has_observer:
            z_f, z_t, d_x, d_w = observer_estimate(v, w, observer_gain, km, fresh[i],
                                                   vector_at(z_force, i),
                                                   vector_at(z_torque, i))
            store_vector(z_force, i, z_f)
            store_vector(z_torque, i, z_t)
            fresh[i] = False
        store_vector(force_estimate, i, d_x)
        store_vector(torque_estimate, i, d_w)
        target = reference_at(reference, reference_row[i])  # read once, for both
        f, m, force, rd, rate_d, acceleration_d, e_r, e_w = geometric_law(
            x, v, R, w, target, law, d_x, d_w, (0.0, 0.0, 0.0))
        store_geometric(i, f, m, force, rd, rate_d, acceleration_d, e_r, e_w, outputs)
        observed = residual_observation(f, m, d_x, d_w, scale, x, v, R, target.position,
                                        target.velocity, inverse)
        store_residual_observation(i, observed, base_action, body_errors, extra)


@njit(cache=True, inline="always")
def remember_state(start, stop, update, plan):
    """The state before the step, which the observer's update needs."""
    velocity_before, body_z_before = update.velocity_before, update.body_z_before
    rate_before = update.rate_before
    velocity, rotation, angular_velocity = plan.velocity, plan.rotation, plan.angular_velocity
    for i in range(start, stop):
        for k in range(3):
            velocity_before[i, k] = velocity[i, k]
            body_z_before[i, k] = rotation[i, k, 2]
            rate_before[i, k] = angular_velocity[i, k]


@njit(cache=True, inline="always")
def reward_and_observer_update(start, stop, update, plan):
    """After the physics step: the residual's reward, and each observer advanced with what
    was applied."""
    residual_reward_kernel(start, stop, update.clipped, update.core_rewards,
                           update.effort_weight, update.rate_weight, update.previous,
                           update.rewards)
    if plan.has_observer:
        inertia_entries = matrix_entries(plan.inertia)
        km = matrix_entries(plan.observer_rotational_gain)
        alpha_entries = matrix_entries(update.rotational_alpha)
        velocity_before, body_z_before = update.velocity_before, update.body_z_before
        rate_before = update.rate_before
        applied_thrust, applied_moment = update.applied_thrust, update.applied_moment
        rotation, angular_velocity = plan.rotation, plan.angular_velocity
        mass, gravity, observer_gain, alpha = (plan.mass, plan.gravity, plan.observer_gain,
                                               update.alpha)
        z_force, z_torque = plan.z_force, plan.z_torque
        advance_torque = update.advance_torque
        for i in range(start, stop):
            z_f, z_t = observer_advance(
                vector_at(velocity_before, i), vector_at(body_z_before, i),
                vector_at(rate_before, i), applied_thrust[i], vector_at(applied_moment, i),
                (rotation[i, 0, 2], rotation[i, 1, 2], rotation[i, 2, 2]),
                vector_at(angular_velocity, i), mass, gravity, inertia_entries, observer_gain,
                alpha, km, alpha_entries, vector_at(z_force, i), vector_at(z_torque, i),
                advance_torque)
            store_vector(z_force, i, z_f)
            store_vector(z_torque, i, z_t)


@njit(cache=True, nogil=True)
def fused_residual_kernel(start, stop, command, actions, vehicles, update, plan):
    """One residual step of vehicles ``start..stop-1`` (``quad_dob_env.threads`` splits the
    batch across cores): ``command`` is what ``residual_command_kernel`` takes, ``vehicles``
    the core's ``StepArguments``, ``update`` an ``UpdateArguments`` and ``plan`` a
    ``PlanArguments``, each passed as plain tuples (a named one costs numba's slow typing
    path every call) and named again here."""
    residual_command_kernel(start, stop, *command)
    update_record, plan_record = UpdateArguments(*update), PlanArguments(*plan)
    remember_state(start, stop, update_record, plan_record)
    step_kernel(start, stop, actions, *vehicles)
    reward_and_observer_update(start, stop, update_record, plan_record)
    plan_kernel(np.arange(start, stop), plan)


@njit(cache=True, nogil=True)
def fused_attitude_kernel(start, stop, command, actions, attitude, vehicles, finish, update,
                          plan):
    """One residual step of vehicles ``start..stop-1`` in a loop with an inner loop and
    sensors (Benchmark v2 and v3): the residual's command, the base's attitude law at every
    tick plus the residual (``attitude``: the ``addition`` array and the ``InnerLaw``,
    ``attitude_loop_kernel``), the sensors, estimator and observation
    (``measured_finish_kernel``, ``finish`` the core's ``finish_arguments``), the reward and
    the observer's update, then the plan on the new estimate. Each stage touches only the
    slice's own rows, so one slice runs them one after the other."""
    residual_command_kernel(start, stop, *command)
    update_record, plan_record = UpdateArguments(*update), PlanArguments(*plan)
    addition, inner_law = attitude
    residual_addition_kernel(start, stop, update_record.clipped, command[1], addition)
    remember_state(start, stop, update_record, plan_record)
    attitude_loop_kernel(start, stop, actions, addition, inner_law, *vehicles)
    measured_finish_kernel(start, stop, *finish)
    reward_and_observer_update(start, stop, update_record, plan_record)
    plan_kernel(np.arange(start, stop), plan)


class FusedResidualStep:
    """One compiled pass per step for a ``ResidualCommand`` whose base is ``controller``:
    ``fused_residual_kernel`` in v1's loop (ideal sensing, no inner loop),
    ``fused_attitude_kernel`` in a loop with an inner loop and sensors (v2, v3);
    ``flies(core)`` says whether a core's loop is one of the two.

    Every step runs on the same arrays, so the kernel's arguments are gathered once (again
    only after a full reset or when the core's tables grew): the residual is copied in, and
    the base command, the observer's estimates and the controller's ``diagnostics`` are
    overwritten in place each step (``ResidualCommand.info`` hands out copies). A vehicle's
    slice reads its planned command before it writes the next, so in place is safe.
    """

    def __init__(self, controller: GeometricController, residual: ResidualCommand) -> None:
        self.controller, self.residual = controller, residual
        core = residual.core
        n = core.n
        self._with_loop = core.loop.active  # the attitude law at the inner rate, sensors
        self._before = (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)))
        self._residual = np.zeros((n, 4))
        self._actions = np.zeros((n, 4))
        self._clipped = np.zeros((n, 4))
        self._addition = np.zeros((n, 4))  # what the attitude law adds at every tick
        self._base_action = np.zeros((n, 4))
        self._body_errors = np.zeros((n, 6))
        self._law: tuple = ()
        self._observer: tuple = ()
        self._observer_rates: tuple = ()
        self._outputs: dict = {}
        self._arguments: tuple = ()
        self._tables = None  # the core's reference table the arguments were made with

    @staticmethod
    def flies(core: Any) -> bool:
        """Whether ``core``'s loop is one a fused pass flies: ideal sensing without an
        inner loop, or sensors with one (the residual's thrust and moments added to the
        attitude law, not ``thrust_rates``' rate law)."""
        if core.loop.active:
            return not core.sensing.identity and not core.loop.rates
        return core.sensing.identity

    def restart(self, indices: NDArray[np.intp]) -> None:
        """After the controller's reset of vehicles ``indices``: their first plan."""
        if not self._law or len(indices) == self.residual.core.n:
            self._gather_constants()  # a full reset may have new gains and observer arrays
            self._new_outputs()
            self._arguments = ()
        plan_kernel(np.asarray(indices, dtype=np.intp), tuple(self._plan_arguments()))

    def step(self, residual: NDArray[np.float64]) -> None:
        """One step of every vehicle with ``residual`` (N, 4), and the plan for the next."""
        core = self.residual.core
        core.prepare_step()
        self._residual[...] = residual
        if not self._arguments or core.reference_table is not self._tables:
            self._make_arguments()  # first step, full reset, or the tables grew
        if self._with_loop:  # the sensors' pass is in the kernel
            run_over_batch(fused_attitude_kernel, core.n, *self._arguments)
            return
        run_over_batch(fused_residual_kernel, core.n, *self._arguments)
        core.finish_step()

    def _make_arguments(self) -> None:
        """What ``fused_residual_kernel`` takes after the slice."""
        core, command = self.residual.core, self.residual
        flown = (self._residual, command.residual_range, command.base_thrust,
                 command.base_moment, core.action_map.inverse, self._clipped,
                 command.requested_thrust, self._actions)
        velocity_before, body_z_before, rate_before = self._before
        alpha, rotational_alpha = self._observer_rates
        update = UpdateArguments(
            velocity_before=velocity_before, body_z_before=body_z_before,
            rate_before=rate_before, alpha=alpha, rotational_alpha=rotational_alpha,
            clipped=self._clipped, core_rewards=core.rewards,
            effort_weight=float(command.effort_weight),
            rate_weight=float(command.rate_weight), previous=command.previous_residual,
            rewards=command.rewards,
            applied_thrust=core.estimator_wrench.thrust,
            applied_moment=core.estimator_wrench.moment,
            advance_torque=not self._with_loop)
        vehicles = kernel_tuples(core.step_arguments())
        update, plan = tuple(update), tuple(self._plan_arguments())
        if self._with_loop:  # the law reads the controller's diagnostics, this pass's own
            attitude = (self._addition, tuple(self.controller.inner_law()))
            self._arguments = (flown, self._actions, attitude, vehicles,
                               core.finish_arguments(), update, plan)
        else:
            self._arguments = (flown, self._actions, vehicles, update, plan)
        self._tables = core.reference_table

    def _gather_constants(self) -> None:
        controller, vehicle = self.controller, self.controller.vehicle
        kx, kv = controller.position_gains
        gains = np.stack([kx, kv, controller.gains["kR"], controller.gains["kOmega"]]).astype(float)
        self._law = (float(vehicle.mass), float(vehicle.gravity),
                     np.array(vehicle.inertia_matrix, dtype=float), gains)
        observer = controller.observer
        if observer is None:
            n = self.residual.core.n
            self._observer = (False, 0.0, np.zeros((3, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
                              np.zeros(n, dtype=np.bool_))
            self._observer_rates = (0.0, np.zeros((3, 3)))
        else:
            state = observer.kernel_state()
            # with an inner loop the estimate reads zΩ with the gains at its tick
            km = (state.rotational_gain if observer.inner_gains is None
                  else np.array(observer.inner_gains[0], dtype=float))
            self._observer = (True, state.translational_gain, km, state.z_force,
                              state.z_torque, state.fresh)
            self._observer_rates = (state.translational_alpha, state.rotational_alpha)

    def _new_outputs(self) -> None:
        """The arrays the plan is written to, from now on."""
        n = self.residual.core.n
        force_estimate, torque_estimate = np.empty((n, 3)), np.empty((n, 3))
        thrust, moment = np.empty(n), np.empty((n, 3))
        diagnostics = {"desired_force": np.empty((n, 3)), "desired_rotation": np.empty((n, 3, 3)),
                       "desired_angular_velocity": np.empty((n, 3)),
                       "desired_angular_acceleration": np.empty((n, 3)),
                       "attitude_error": np.empty((n, 3)), "rate_error": np.empty((n, 3))}
        self._outputs = {"force_estimate": force_estimate, "torque_estimate": torque_estimate,
                         "thrust": thrust, "moment": moment,
                         "desired_force": diagnostics["desired_force"],
                         "desired_rotation": diagnostics["desired_rotation"],
                         "desired_rate": diagnostics["desired_angular_velocity"],
                         "desired_acceleration": diagnostics["desired_angular_acceleration"],
                         "attitude_error": diagnostics["attitude_error"],
                         "rate_error": diagnostics["rate_error"]}
        self.controller.diagnostics = {**diagnostics, "force_estimate": force_estimate,
                                       "torque_estimate": torque_estimate}
        if self.controller.observer is not None:
            self.controller.observer.force_estimate = force_estimate
            self.controller.observer.torque_estimate = torque_estimate
        self.residual.base_thrust, self.residual.base_moment = thrust, moment
        self.residual.force_estimate, self.residual.torque_estimate = (force_estimate,
                                                                      torque_estimate)

    def _plan_arguments(self) -> PlanArguments:
        core = self.residual.core
        state = core.sensing.measurement  # the estimate; the truth's arrays when ideal
        mass, gravity, inertia, gains = self._law
        has_observer, gain, rotational_gain, z_force, z_torque, fresh = self._observer
        return PlanArguments(
            position=state.position, velocity=state.velocity, rotation=state.rotation,
            angular_velocity=state.angular_velocity, reference=core.reference_table,
            reference_row=core.reference_row, mass=mass, gravity=gravity, inertia=inertia,
            gains=gains, has_observer=has_observer, observer_gain=gain,
            observer_rotational_gain=rotational_gain, z_force=z_force, z_torque=z_torque,
            fresh=fresh, **self._outputs,
            estimate_scale=self.residual.estimate_scale, inverse=core.action_map.inverse,
            base_action=self._base_action, body_errors=self._body_errors,
            extra=self.residual.extra_observation)
