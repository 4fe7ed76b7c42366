"""The residual's observation entries, after the env's own: what ``ResidualCommand`` and
the compiled ``residual_observation`` write, named (``quad_dob_env.envs.observation``
puts them in the env's table and gives them columns).

Imports only the entry record; a test holds each entry to the columns the
kernels write. ``ResidualOptions.observation_entries`` hands them to the env's table, which
sits below the residual and does not import it.
"""

from __future__ import annotations

from quad_dob_env.observation_entry import UNBOUNDED, ObservationEntry

# Always there, in this order, from the measurement the base controller reads.
RESIDUAL_ENTRIES = (
    ObservationEntry("base_command", "the base controller's command as a normalised action "
                     "(thrust, Mx, My, Mz); with the acceleration mode, the command flown the "
                     "step before", "-", 4, (-1.0, 1.0)),
    ObservationEntry("force_estimate", "the observer's force estimate d̂x / (m g) (0 without "
                     "an observer)", "-", 3, UNBOUNDED),
    ObservationEntry("torque_estimate", "the observer's torque estimate d̂Ω / moment limit",
                     "-", 3, UNBOUNDED),
    ObservationEntry("body_position_error", "position error in the body frame, Rᵀ(x - x_d)",
                     "m", 3, UNBOUNDED),
    ObservationEntry("body_velocity_error", "velocity error in the body frame, Rᵀ(v - v_d)",
                     "m/s", 3, UNBOUNDED),
)
