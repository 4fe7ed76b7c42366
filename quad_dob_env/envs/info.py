"""The numbers of every vehicle's ``info``, written in one compiled pass, and their layout."""

from __future__ import annotations

from numba import njit

# info entries per vehicle, as columns of one block (info_kernel writes them)
INFO_COLUMNS = (("time", 0), ("position_error", slice(1, 4)), ("velocity_error", slice(4, 7)),
               ("reference_position", slice(7, 10)), ("reference_velocity", slice(10, 13)),
               ("reference_acceleration", slice(13, 16)), ("reference_heading", slice(16, 19)),
               ("disturbance_force", slice(19, 22)), ("disturbance_torque", slice(22, 25)),
               ("applied_thrust", 25), ("applied_moment", slice(26, 29)),
               ("rotor_thrusts", slice(29, 33)))
INFO_WIDTH = 33


@njit(cache=True)
def info_kernel(position, velocity, step_count, reference_row, dt, reference,
                disturbance_force, disturbance_torque, applied_thrust, applied_moment,
                rotor_thrusts, out):
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
