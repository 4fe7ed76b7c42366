"""The residual's observation entries, after the env's own: what ``ResidualCommand`` and
the compiled ``residual_observation`` write, named (``quad_dob_env.envs.observation``
puts them in the env's table and gives them columns).

Imports only the entry record; a test holds each entry to the columns the
kernels write. ``ResidualOptions.observation_entries`` hands them to the env's table, which
sits below the residual and does not import it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from quad_dob_env.observation_entry import UNBOUNDED, ObservationEntry

if TYPE_CHECKING:  # the record only: options imports this module
    from quad_dob_env.residual.options import ResidualOptions

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


def loop_entries(options: ResidualOptions) -> tuple[ObservationEntry, ...]:
    """The loop view's entries (``loop_view``), after ``RESIDUAL_ENTRIES``, for the options
    that ask for them; none for the defaults."""
    history_steps = options.history_steps
    entries = []
    if history_steps:
        entries += [
            ObservationEntry("residual_history", f"the residual flown at each of the last "
                             f"{history_steps} steps (4 each, clipped and faded), newest first",
                             "-", 4 * history_steps, (-1.0, 1.0)),
            ObservationEntry("velocity_error_history", f"the body-frame velocity error at the "
                             f"start of each of the last {history_steps} steps (3 each), newest "
                             "first", "m/s", 3 * history_steps, UNBOUNDED)]
    if options.thrust_path_input:
        entries.append(ObservationEntry(
            "thrust_path_residual", "(accelerometer's body-z specific force - commanded "
            "thrust / m) / g₀, low-passed at 5 Hz", "-", 1, UNBOUNDED))
    if options.period_input:
        entries.append(ObservationEntry("control_period", "the control period / 10 ms", "-", 1,
                                        (0.0, float("inf"))))
    if options.reference_jerk_input:
        entries.append(ObservationEntry("desired_jerk", "the reference's jerk x⃛_d at the "
                                        "step (world frame)", "m/s³", 3, UNBOUNDED))
    return tuple(entries)
