"""The numbers of every vehicle's ``info``, written in one compiled pass, and their layout."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit
from numpy.typing import NDArray

if TYPE_CHECKING:
    from quad_dob_env.envs.core import QuadrotorBatch


# info entries per vehicle, as columns of one block (info_kernel writes them)
INFO_COLUMNS = (("time", 0), ("position_error", slice(1, 4)), ("velocity_error", slice(4, 7)),
               ("reference_position", slice(7, 10)), ("reference_velocity", slice(10, 13)),
               ("reference_acceleration", slice(13, 16)), ("reference_heading", slice(16, 19)),
               ("disturbance_force", slice(19, 22)), ("disturbance_torque", slice(22, 25)),
               ("applied_thrust", 25), ("applied_moment", slice(26, 29)),
               ("rotor_thrusts", slice(29, 33)), ("wind", slice(33, 36)))
# info["estimate"]'s entries, in the same block
ESTIMATE_COLUMNS = (("position", slice(36, 39)), ("velocity", slice(39, 42)),
                    ("rotation", slice(42, 51)), ("angular_velocity", slice(51, 54)))
INFO_WIDTH = 54


@njit(cache=True)
def info_kernel(position, velocity, step_count, reference_row, dt, reference,
                disturbance_force, disturbance_torque, applied_thrust, applied_moment,
                rotor_thrusts, wind, estimated_position, estimated_velocity,
                estimated_rotation, estimated_rates, out):
    """Each vehicle's ``info`` numbers as one row of ``out`` (layout:
    ``QuadrotorBatch.info_arrays``)."""
    for i in range(position.shape[0]):
        r = reference_row[i]
        out[i, 0] = step_count[i] * dt
        for k in range(3):
            out[i, 1 + k] = position[i, k] - reference[r, 0, k]
            out[i, 4 + k] = velocity[i, k] - reference[r, 1, k]
            out[i, 7 + k] = reference[r, 0, k]
            out[i, 10 + k] = reference[r, 1, k]
            out[i, 13 + k] = reference[r, 2, k]
            out[i, 16 + k] = reference[r, 5, k]
            out[i, 19 + k] = disturbance_force[i, k]
            out[i, 22 + k] = disturbance_torque[i, k]
            out[i, 26 + k] = applied_moment[i, k]
        out[i, 25] = applied_thrust[i]
        for k in range(4):
            out[i, 29 + k] = rotor_thrusts[i, k]
        for k in range(3):
            out[i, 33 + k] = wind[i, k]
            out[i, 36 + k] = estimated_position[i, k]
            out[i, 39 + k] = estimated_velocity[i, k]
            out[i, 51 + k] = estimated_rates[i, k]
            for c in range(3):
                out[i, 42 + 3 * k + c] = estimated_rotation[i, k, c]


def info_arrays(core: QuadrotorBatch) -> dict[str, NDArray | dict[str, NDArray]]:
    """Every vehicle's ``info`` numbers now, (N,) or (N, k) each: ``time``, the position
    and velocity errors, the reference (position, velocity, acceleration, heading), the
    true disturbance force and torque, the applied thrust, moment and rotor thrusts,
    ``actuator_saturated``, ``wind`` (the air's velocity at the vehicle over the last step,
    world frame; zero at a reset, as the disturbance) and
    ``estimate``, a dict of what the policies read (``position``, ``velocity``,
    ``rotation``, ``angular_velocity``: the true state with ideal sensing). New arrays
    each call (views of one block, filled in one compiled pass)."""
    block = np.empty((core.n, INFO_WIDTH))
    s, applied = core.state, core.applied
    m = core.sensing.measurement
    info_kernel(s.position, s.velocity, core.step_count, core.reference_row,
                core.scenario.dt, core.reference_table, core.disturbance_force,
                core.disturbance_torque, applied.thrust, applied.moment, applied.rotor_thrusts,
                core.wind_velocity, m.position, m.velocity, m.rotation, m.angular_velocity,
                block)
    info: dict = {name: block[:, columns] for name, columns in INFO_COLUMNS}
    info["actuator_saturated"] = applied.saturated.copy()
    estimate = {name: block[:, columns] for name, columns in ESTIMATE_COLUMNS}
    estimate["rotation"] = estimate["rotation"].reshape(-1, 3, 3)
    info["estimate"] = estimate
    return info
