"""Delay margins: how much latency a policy's flights take before one is lost.

A policy's delay margin on a scenario is the largest extra latency of a grid such that it,
and every smaller value of the grid, keeps every flight of the seeds (none crashed, left
its bounds or lost its attitude). The grid is searched upwards and stops at the first value
that loses a flight, so a margin never rests on a lucky larger value. Where the latency
goes (``DELAY_PATHS``) is each benchmark's margin's place (``benchmark_delay_path``): v1's
and v2's on every reading (``LoopOptions.extra_latency``: pose, IMU and rotors alike), v3's on
the pose fix alone, unknown to the estimator (``LoopOptions.unmodelled_pose_latency``, where
``benchmark_v3.TUNING_MARGIN`` puts its 20 ms: a real vehicle's mocap and link latency do
not reach its autopilot's IMU).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # flying imports the simulator and torch: the CLI's parser reads this
    from quad_dob_env.scenario import Scenario
    from quad_dob_training.policies import Policy
    from quad_dob_training.rollout import Flight

# [s] the grid quad-dob evaluate searches by default: whole control steps at 100 Hz
DELAY_GRID = (0.0, 0.01, 0.02, 0.03, 0.05, 0.08)
# where the extra latency is added -> the Scenario field that adds it there
DELAY_PATHS = {"readings": "extra_latency", "pose": "unmodelled_pose_latency"}


def benchmark_delay_path(benchmark: str) -> str:
    """Where ``benchmark``'s tuning margin puts its latency: ``"pose"`` for v3 and v4 (its
    margin is v3's), else ``"readings"``."""
    return "pose" if benchmark in ("v3", "v4") else "readings"


@dataclass(frozen=True)
class DelayMargin:
    """``margin`` [s]: the largest grid value that kept every flight (None: flights are
    lost at the grid's first value); ``lost_at``: the first value that lost one (None:
    none did, the margin is at least the grid's last); ``grid``: what was searched."""

    margin: float | None
    lost_at: float | None
    grid: tuple[float, ...]

    def describe(self) -> str:
        """``"20 ms"``, ``">= 80 ms"``, or ``"< 0 ms (loses flights at 0 ms)"``, in ms."""
        if self.margin is None:
            return f"none (loses flights at {1000 * self.grid[0]:g} ms)"
        prefix = ">= " if self.lost_at is None else ""
        return f"{prefix}{1000 * self.margin:g} ms"


def check_grid(grid: Sequence[float] | str) -> tuple[float, ...]:
    """The grid (or ``"0,0.01,0.02"``) as increasing latencies >= 0 [s], or a ValueError
    that says what is allowed."""
    try:
        values = tuple(float(value) for value in (
            grid.split(",") if isinstance(grid, str) else grid))
    except (TypeError, ValueError):
        values = ()
    if (not values or any(not value >= 0 for value in values)
            or list(values) != sorted(set(values))):
        raise ValueError(f"the delay grid must be increasing latencies >= 0 [s], such as "
                         f"{','.join(f'{v:g}' for v in DELAY_GRID)}; got {grid!r}")
    return values


def delay_margin(policy: Policy, scenario: str | Scenario, seeds: list[int],
                 scenario_options: dict[str, object] | None = None,
                 grid: Sequence[float] = DELAY_GRID,
                 flown: list[Flight] | None = None, path: str = "readings") -> DelayMargin:
    """``policy``'s delay margin on ``scenario`` (a name, or a ``Scenario``) over ``seeds``
    (module docstring), the latency added on ``path`` (a ``DELAY_PATHS`` key) to whatever
    ``scenario_options`` already set there. ``flown``: the flights already flown with those
    options, which stand for a grid's first value of 0."""
    from quad_dob_env.scenarios import make_scenario
    from quad_dob_training.policies import fly_policy

    if path not in DELAY_PATHS:
        raise ValueError(f"the delay path must be one of {', '.join(DELAY_PATHS)} (where "
                         f"the extra latency goes), got {path!r}")
    field = DELAY_PATHS[path]
    values = check_grid(grid)
    options = dict(scenario_options or {})
    base_latency = float(options.pop(field, 0.0))
    margin = None
    for latency in values:
        if latency == 0.0 and flown is not None:
            flights = flown
        else:
            flights = fly_policy(policy, make_scenario(
                scenario, **options, **{field: base_latency + latency}), seeds)
        if any(flight.termination_reason not in ("", "time_limit") for flight in flights):
            return DelayMargin(margin, latency, values)
        margin = latency
    return DelayMargin(margin, None, values)
