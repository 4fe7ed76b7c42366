"""The residual observation's look-ahead (``quad_dob_env.residual``): the error against
the reference at given times ahead, in the body frame the present errors use."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.validation import as_finite

if TYPE_CHECKING:
    from quad_dob_env.envs.core import QuadrotorBatch

MAX_LOOKAHEAD = 2.0  # [s] how far ahead the observation may read the reference


def lookahead_steps(lookahead: Sequence[float], dt: float) -> NDArray[np.int64]:
    """The look-ahead times [s] as whole control steps: each in (0, ``MAX_LOOKAHEAD``] and a
    multiple of ``dt`` (the reference is tabulated on the control grid), increasing."""
    times = [as_finite(t, "lookahead time", 0.0, strictly=True) for t in lookahead]
    steps = [round(t / dt) for t in times]
    for time, step in zip(times, steps, strict=True):
        if time > MAX_LOOKAHEAD or abs(step * dt - time) > 1e-9 * max(1.0, time):
            raise ValueError(f"lookahead times must be multiples of the control step {dt:g} s "
                             f"in (0, {MAX_LOOKAHEAD:g}] s, got {time:g}")
    if steps != sorted(set(steps)):
        raise ValueError(f"lookahead times must increase, got {list(lookahead)!r}")
    return np.array(steps, dtype=np.int64)


def look_ahead(core: QuadrotorBatch, steps: NDArray[np.int64], out: NDArray[np.float32]
               ) -> None:
    """``out`` (N, 3K) = R̂ᵀ(x̂ - x_d(t + τ_k)) for each of the K ``steps``, from the
    measurement the base read. The residual has the core tabulate the reference that far
    past the episode's end (``tabulate_ahead``); a vehicle flown past even that reads its
    member's last row (a family stacks its members' blocks)."""
    if not len(steps):
        return
    measurement = core.measurement
    members = len(getattr(core.scenario.trajectory, "members", (None,)))
    rows = len(core.reference_table) // members
    last = (core.reference_row // rows) * rows + rows - 1
    ahead = np.minimum(core.reference_row[:, None] + steps, last[:, None])
    offset = measurement.position[:, None, :] - core.reference_table[ahead, 0]
    body = np.einsum("nji,nkj->nki", measurement.rotation, offset)  # Rᵀ(x̂ - x_d), (N, K, 3)
    out[:] = np.clip(body.reshape(core.n, -1), -1e3, 1e3)
