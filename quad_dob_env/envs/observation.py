"""Every observation entry by name, unit, range and columns: one table for each layout an
env can take.

The env's own entries (``env_entries``) come first; the compiled ``observe_vehicle``
(``step_kernels``) writes them. A residual env appends the residual's, which its options
name (``ResidualOptions.observation_entries``: ``quad_dob_env.residual.observation``, a
layer above this one, so they come in through the options rather than an import).
``observation_table`` places them one after another and gives each its columns; the core's
and the residual's observation sizes are the table's, and a test holds every entry to the
columns the kernels write. The env pages of the docs are generated from it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Protocol

from quad_dob_env.observation_entry import UNBOUNDED, ObservationEntry
from quad_dob_env.validation import unknown_name_error


class AppendedEntries(Protocol):
    """What appends entries after the env's own: ``quad_dob_env.residual.ResidualOptions``
    (the residual sits above the envs, so the table takes its entries from the options)."""

    @property
    def observation_entries(self) -> tuple[ObservationEntry, ...]: ...


# the rotation's entries per representation: R row-major, or its first two columns
# (Zhou et al., "On the continuity of rotation representations in neural networks", 2019)
ROTATION_ENTRIES = {
    "matrix": ObservationEntry("rotation", "rotation matrix R (body to world), row-major",
                               "-", 9, (-1.0, 1.0)),
    "6d": ObservationEntry("rotation", "R's first two columns, one after the other", "-", 6,
                           (-1.0, 1.0)),
}


def env_entries(rotation_representation: str = "matrix") -> tuple[ObservationEntry, ...]:
    """The env's own entries, world frame unless stated, before any residual's."""
    if rotation_representation not in ROTATION_ENTRIES:
        raise unknown_name_error("rotation_representation", rotation_representation,
                                 ROTATION_ENTRIES)
    return (
        ObservationEntry("position_error", "position error x - x_d", "m", 3, UNBOUNDED),
        ObservationEntry("velocity_error", "velocity error v - v_d", "m/s", 3, UNBOUNDED),
        ROTATION_ENTRIES[rotation_representation],
        ObservationEntry("body_rates", "body rates Ω (body frame)", "rad/s", 3, UNBOUNDED),
        ObservationEntry("desired_acceleration", "desired acceleration ẍ_d (the reference's "
                         "feed-forward)", "m/s²", 3, UNBOUNDED),
        ObservationEntry("desired_heading", "desired heading b1d (a unit vector)", "-", 3,
                         (-1.0, 1.0)),
    )


def placed(entries: Sequence[ObservationEntry], start: int = 0) -> tuple[ObservationEntry, ...]:
    """``entries`` one after another from column ``start``."""
    table = []
    for entry in entries:
        table.append(replace(entry, start=start))
        start += entry.size
    return tuple(table)


def observation_size(entries: Sequence[ObservationEntry]) -> int:
    """How many columns ``entries`` take."""
    return sum(entry.size for entry in entries)


def observation_table(rotation_representation: str = "matrix",
                      residual: AppendedEntries | None = None) -> tuple[ObservationEntry, ...]:
    """The observation's entries with their columns: the env's, then (for an env with a
    base controller, ``residual`` its ``ResidualOptions``) the residual's, the same for
    every option set."""
    entries = env_entries(rotation_representation)
    if residual is not None:
        entries += tuple(residual.observation_entries)
    return placed(entries)
