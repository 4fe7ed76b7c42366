"""A controller's attitude law inside the env's step, at the inner loop's rate (Benchmark
v2's loop structure).

With a scenario's ``inner_rate`` the core flies each control step as ``ticks`` intervals.
``AttitudeLoop`` is what a flight installs on the core (``QuadrotorBatch.attitude_loop``)
to fly a controller there: the controller's ``compute`` (its outer part: position, the
translational observer, a residual policy) runs once per control step on the estimate;
then for every tick, per vehicle, one compiled pass runs

    inner-rate estimate -> the controller's attitude law (``quad_dob_baselines.inner``)
    + the residual's addition -> mixer -> motors -> physics -> the law's own update
    (rotational observer, PID integrator)

through the same per-vehicle pieces the core's own step uses
(``quad_dob_env.envs.step_kernels``: ``inner_estimate``, ``fly_tick``, ``finish_vehicle_step``),
so there is one source for every equation. Vehicle ``i`` of the core is row
``rows.start + i`` of the controller's batch (``training.rollout`` flies several N = 1
cores as one batch).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_baselines.inner import PID, InnerLaw, inner_applied, inner_command
from quad_dob_env.dynamics import (
    actuate_vehicle,
    actuator_wrench,
    all_finite,
    load_vehicle,
    vehicle_physics,
)
from quad_dob_env.envs.step_kernels import finish_vehicle_step
from quad_dob_env.envs.ticks import (
    filtered_rate,
    fly_tick,
    held_rate,
    inner_estimate,
    keep_pose,
    thrust_path_at,
    tick_factors,
)
from quad_dob_env.threads import run_over_batch


@njit(cache=True, nogil=True)
def attitude_loop_kernel(start, stop, addition, law, actions, action_map, actuation, actuator,
                         rotors, rotor_state, inner, position, velocity, rotation,
                         angular_velocity, step_count, reference_row, tables, own, reference,
                         physics, dt, substeps, law_table, limits, reward_weights,
                         rotation_mode, obs, reward, code, applied_thrust, applied_moment,
                         rotor_thrusts, saturated, disturbance_force, disturbance_torque,
                         wind_velocity):
    """One control step of vehicles ``start..stop-1`` with the controller's attitude law
    (``law``, an ``InnerLaw`` as a plain tuple) at every tick, plus ``addition`` (N, 4),
    a residual's thrust and moment. Called as ``step_kernel`` is, with
    ``*StepArguments`` after ``actions`` (its ``law`` field, the ground effect's, arrives as
    ``law_table``); ``actions`` only enter the reward's effort term."""
    to_wrench, _, time_constant, actuator_state = actuator
    mass, gravity, inertia, inertia_inverse, drag = physics
    ticks, limit = inner[0], inner[4]
    mixer_code, mixer, max_rotor, max_total, mixer_limit = actuation
    tick_dt = dt / ticks
    mean_factor, end_factor = tick_factors(time_constant, tick_dt)
    for i in range(start, stop):
        row = step_count[i]
        vehicle = vehicle_physics(i, mass, gravity, inertia, inertia_inverse, drag)
        x, v, R, w = load_vehicle(i, position, velocity, rotation, angular_velocity)
        battery = thrust_path_at(i, row, dt, rotors, rotor_state, vehicle)
        r0, w0 = R, w
        end = (actuator_state[i, 0], actuator_state[i, 1], actuator_state[i, 2],
               actuator_state[i, 3])
        total = (0.0, 0.0, 0.0, 0.0)
        any_saturated, diverged = False, False
        seen_rotation, seen_rate = inner_estimate(i, R, w, inner, r0, w0)
        seen_rate = held_rate(i, seen_rate, inner)  # the gyro low-pass's, when on
        for tick in range(ticks):
            own_thrust, own_moment = inner_command(i, seen_rotation, seen_rate, law, tick_dt)
            # the residual's part, and the limits a command in the action space has
            thrust = min(max(own_thrust + addition[i, 0], 0.0), max_total)
            moment = (min(max(own_moment[0] + addition[i, 1], -limit[0]), limit[0]),
                      min(max(own_moment[1] + addition[i, 2], -limit[1]), limit[1]),
                      min(max(own_moment[2] + addition[i, 3], -limit[2]), limit[2]))
            xn, vn, Rn, wn, next_end, mean, hit, _ = fly_tick(
                i, x, v, R, w, end, thrust, moment, actuation, actuator, rotors, rotor_state,
                battery, tables, own, row, vehicle, tick_dt, substeps, law_table,
                2 * substeps * tick, mean_factor, end_factor)
            end = next_end
            total = (total[0] + mean[0], total[1] + mean[1], total[2] + mean[2],
                     total[3] + mean[3])
            any_saturated = any_saturated or hit
            if not all_finite(xn, vn, Rn, wn):
                diverged = True
                break
            x, v, R, w = xn, vn, Rn, wn
            keep_pose(i, tick + 1, x, v, R, inner)
            rotation_after, rate_after = inner_estimate(i, R, w, inner, r0, w0)
            rate_after = filtered_rate(i, rate_after, inner)
            # the law's own request, what the mixer makes of it (the PID's anti-windup),
            # what the motors gave (the observer)
            mixed_moment = own_moment
            if law[0] == PID:
                mixed, _ = actuate_vehicle(own_thrust, own_moment, mixer_code, mixer,
                                           max_rotor, max_total, mixer_limit)
                mixed_moment = actuator_wrench(mixed, mixed, 0.0, to_wrench)[1]
            inner_applied(i, seen_rate, rate_after, own_moment, mixed_moment,
                          actuator_wrench(mean, mean, 0.0, to_wrench)[1], law)
            seen_rotation, seen_rate = rotation_after, rate_after
        finish_vehicle_step(i, x, v, R, w, diverged, end, total, ticks, any_saturated, actions,
                            actuator, rotors, rotor_state, position, velocity, rotation,
                            angular_velocity, step_count, reference_row, tables, own,
                            reference, vehicle, law_table, limits, reward_weights,
                            rotation_mode, obs, reward, code, applied_thrust, applied_moment,
                            rotor_thrusts, saturated, disturbance_force, disturbance_torque,
                            wind_velocity)


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
            self._arguments = tuple(core.step_arguments())
            self._tables = core.reference_table
        run_over_batch(attitude_loop_kernel, core.n, self.addition, tuple(law), actions,
                       *self._arguments)
