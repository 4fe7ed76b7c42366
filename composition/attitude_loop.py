"""A controller's attitude law inside the env's step, at the inner loop's rate (Benchmark
v2's loop structure).

With a scenario's ``inner_rate`` the core flies each control step as ``ticks`` intervals.
``AttitudeLoop`` is what a flight installs on the core (``QuadrotorBatch.attitude_loop``)
to fly a controller there: the controller's ``compute`` (its outer part: position, the
translational observer, a residual policy) runs once per control step on the estimate;
then for every tick, per vehicle, the env's one tick loop
(``quad_dob_env.envs.step_kernels.fly_vehicles``) runs

    inner-rate estimate -> the controller's attitude law (``quad_dob_baselines.inner``)
    + the residual's addition -> mixer -> motors -> physics -> the law's own update
    (rotational observer, PID integrator)

with the law given here (``attitude_constants``, ``attitude_start``, ``attitude_command``,
``attitude_after_tick``, ``attitude_end``: the law's part of each vehicle travels through
the ticks as numbers), so there is one loop over ticks and one source for every equation;
this module holds none. Vehicle ``i``
of the core is row ``rows.start + i`` of the controller's batch (``training.rollout``
flies several N = 1 cores as one batch).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_baselines.inner import (
    PID,
    InnerConstants,
    InnerLaw,
    VehicleInner,
    inner_applied,
    inner_command,
    inner_constants,
    store_vehicle_inner,
    vehicle_inner,
)
from quad_dob_env.dynamics import actuate_vehicle, actuator_wrench
from quad_dob_env.envs.step_kernels import fly_vehicles, kernel_tuples, named_step
from quad_dob_env.threads import run_over_batch

# The law ``fly_vehicles`` flies at every tick here: a controller's ``InnerLaw``, its fields
# flat, and ``addition`` (N, 4), the residual's thrust and moment added to its command.
AttitudeLaw = NamedTuple("AttitudeLaw", [*((name, Any) for name in InnerLaw._fields),
                                         ("addition", NDArray)])


class AttitudeConstants(NamedTuple):
    """The attitude law's constants as numbers, once a call: the law's own and the moment
    limits of the action space."""

    inner: InnerConstants
    moment_limit: tuple  # (3,) [N m]


class VehicleAttitude(NamedTuple):
    """Vehicle i's part of the attitude law over a step, as numbers: the law's
    (``VehicleInner``) and the residual's addition (thrust, moment)."""

    inner: VehicleInner
    addition: tuple  # (4,)


@njit(cache=True, inline="always")
def attitude_constants(law, inner):
    """``law``'s ``AttitudeConstants`` (``inner``: the core's ``InnerLoop``)."""
    return AttitudeConstants(inner_constants(law), inner.moment_limit)


@njit(cache=True, inline="always")
def attitude_start(i, law):
    """Vehicle i's ``VehicleAttitude`` from ``law``'s arrays."""
    addition = law.addition
    return VehicleAttitude(vehicle_inner(i, law), (addition[i, 0], addition[i, 1],
                                                    addition[i, 2], addition[i, 3]))


@njit(cache=True, inline="always")
def attitude_command(action, rotation, rate, body, tick_dt, constants, vehicle, mixing):
    """The controller's attitude law at the tick, plus the residual's part, within the
    limits a command in the action space has; the law's own request is kept for its
    update."""
    own_thrust, own_moment, law_after = inner_command(rotation, rate, constants.inner,
                                                      vehicle.inner, tick_dt)
    addition, limit = vehicle.addition, constants.moment_limit
    thrust = min(max(own_thrust + addition[0], 0.0), mixing.max_total_thrust)
    moment = (min(max(own_moment[0] + addition[1], -limit[0]), limit[0]),
              min(max(own_moment[1] + addition[2], -limit[1]), limit[1]),
              min(max(own_moment[2] + addition[3], -limit[2]), limit[2]))
    return (thrust, moment, (own_thrust, own_moment[0], own_moment[1], own_moment[2]),
            VehicleAttitude(law_after, addition))


@njit(cache=True, inline="always")
def attitude_after_tick(rate_before, rate_after, request, mean, constants, vehicle, mixing):
    """The law's own update after a tick: what the mixer makes of its request (the PID's
    anti-windup), what the motors gave (the rotational observer)."""
    own_thrust, own_moment = request[0], (request[1], request[2], request[3])
    mixed_moment = own_moment
    if constants.inner.code == PID:
        mixed, _ = actuate_vehicle(own_thrust, own_moment, mixing.code, mixing.mixer,
                                   mixing.max_rotor_thrust, mixing.max_total_thrust,
                                   mixing.moment_limit)
        mixed_moment = actuator_wrench(mixed, mixed, 0.0, mixing.to_wrench)[1]
    law_after = inner_applied(rate_before, rate_after, own_moment, mixed_moment,
                              actuator_wrench(mean, mean, 0.0, mixing.to_wrench)[1],
                              constants.inner, vehicle.inner)
    return VehicleAttitude(law_after, vehicle.addition)


@njit(cache=True, inline="always")
def attitude_end(i, law, vehicle):
    """The law's own state written back."""
    store_vehicle_inner(i, law, vehicle.inner)


@njit(cache=True, nogil=True)
def attitude_loop_kernel(start, stop, actions, addition, inner_law, action_map, state, body,
                         actuator, rotors, draws, inner, forcing, episode, outputs):
    """One control step of vehicles ``start..stop-1`` with the controller's attitude law
    (``inner_law``, an ``InnerLaw`` as a plain tuple) at every tick, plus ``addition``
    (N, 4), a residual's thrust and moment: the env's one tick loop
    (``quad_dob_env.envs.step_kernels.fly_vehicles``) with this law. Called as
    ``step_kernel`` is, with the core's ``StepArguments`` after ``inner_law``; ``actions``
    only enter the reward's effort term."""
    loop = named_step(action_map, state, body, actuator, rotors, draws, inner, forcing,
                      episode, outputs)
    fly_vehicles(start, stop, actions, loop, AttitudeLaw(*inner_law, addition),
                 attitude_constants, attitude_start, attitude_command, attitude_after_tick,
                 attitude_end, True)


class AttitudeLoop:
    """Flies ``controller``'s attitude law at ``core``'s inner rate: ``core.step`` hands its
    actions here once installed (``core.attitude_loop = AttitudeLoop(core, controller)``).

    ``addition`` (N, 4) is added to the law's thrust and moment at every tick (a residual
    writes it before each step; zero otherwise). ``rows``: the core's vehicles are these
    rows of the controller's batch (default: all of it).
    """

    def __init__(self, core: Any, controller: Any, rows: slice | None = None) -> None:
        self.core, self.controller, self.rows = core, controller, rows
        self.addition = np.zeros((core.n, 4))
        self._arguments: tuple = ()  # the core's step arguments, kept while its tables are
        self._tables = None

    @staticmethod
    def install(core: Any, controller: Any, rows: slice | None = None) -> AttitudeLoop | None:
        """Tell ``controller`` whether ``core`` has an inner loop and, if it does and the
        controller has an attitude law for it, install and return the loop (else None:
        the controller's command is held over the step, as without an inner loop)."""
        period = core.scenario.dt / core.loop.ticks if core.loop.active else None
        controller.use_inner_loop(period)
        if period is None or not controller.has_inner_law:
            core.attitude_loop = None
            return None
        loop = AttitudeLoop(core, controller, rows)
        core.attitude_loop = loop
        return loop

    def step(self, actions: NDArray[np.float64]) -> None:
        """One control step of the core's batch (``core.step`` calls it between its
        ``prepare_step`` and ``finish_step``)."""
        law: InnerLaw = self.controller.inner_law()
        if self.rows is not None:
            rows = self.rows
            law = law._replace(**{name: getattr(law, name)[rows] for name in (
                "desired_force", "desired_rotation", "desired_rate", "desired_acceleration",
                "torque_state", "integral", "previous_error", "fresh", "excess")})
        core = self.core
        if core.reference_table is not self._tables:  # built once per table, as the core does
            self._arguments = kernel_tuples(core.step_arguments())
            self._tables = core.reference_table
        run_over_batch(attitude_loop_kernel, core.n, actions, self.addition, tuple(law),
                       *self._arguments)
