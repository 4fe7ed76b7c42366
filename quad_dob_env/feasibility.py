"""Can a vehicle fly this reference at all? Peak needs by differential flatness, against limits.

For an ideal vehicle without disturbance, the reference's derivatives fix everything it must
do (``quad_dob_env.flatness``): thrust ``f = m ‖ẍd + g e3‖``, body rates Ωd and Ω̇d from jerk
and snap, and moment ``M = J Ω̇d + Ωd × J Ωd``. ``check_reference`` samples them on the
control grid and sets each axis's peak against what the actuators give:

| axis | need | limit |
|---|---|---|
| ``thrust`` | max f | 4 f_max |
| ``moment_x``, ``moment_y``, ``moment_z`` | max abs(M_i) | ``vehicle.moment_limit(actuation)`` |
| ``rotors`` (rotor actuation) | max abs(t_k - f_max/2), t_k mixed rotor thrusts | f_max/2 |
| ``body_rate`` | max ‖Ωd‖ | ``vehicle.max_body_rate`` (the gyroscope's range) |

The ``rotors`` row holds every rotor thrust in [0, f_max]. ``margin = 1 - need / limit``:
the share of the limit left over. Disturbances (wind, gusts) need more on top, so a
scenario's margins say how much room it leaves the controller.
A reference that needs more than a limit (a margin below zero) is one no controller can fly;
``Scenario`` refuses it unless built with ``allow_infeasible=True``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from quad_dob_env.flatness import flat_inputs
from quad_dob_env.params import VehicleParams
from quad_dob_env.trajectories import Trajectory

# what every named scenario of Benchmark v1 keeps on each axis, at least (a test holds it)
BENCHMARK_MARGIN = 0.2

AXIS_NAMES = {
    "thrust": "collective thrust [N]",
    "moment_x": "roll moment (x) [N m]",
    "moment_y": "pitch moment (y) [N m]",
    "moment_z": "yaw moment (z) [N m]",
    "rotors": "rotor thrust off mid-range [N]",
    "body_rate": "body rate [rad/s]",
}


@dataclass(frozen=True)
class AxisNeed:
    """The peak need of one axis over the reference, when it happens, and its limit."""

    axis: str
    peak: float
    limit: float
    time: float

    @property
    def margin(self) -> float:
        return 1.0 - self.peak / self.limit

    def describe(self) -> str:
        return (f"{AXIS_NAMES[self.axis]}: needs {self.peak:.4g} at t = {self.time:.2f} s, "
                f"limit {self.limit:.4g} (margin {self.margin:+.0%})")


@dataclass(frozen=True)
class Feasibility:
    """Every axis's need against its limit; ``feasible`` when none is over."""

    needs: tuple[AxisNeed, ...]

    @property
    def feasible(self) -> bool:
        return all(need.margin >= 0.0 for need in self.needs)

    @property
    def worst(self) -> AxisNeed:
        return min(self.needs, key=lambda need: need.margin)

    def margins(self) -> dict[str, float]:
        return {need.axis: need.margin for need in self.needs}

    def summary(self) -> str:
        """One line: each axis's margin."""
        return ", ".join(f"{need.axis} {need.margin:+.0%}" for need in self.needs)


def check_reference(trajectory: Trajectory, vehicle: VehicleParams, actuation: str,
                    duration: float, dt: float) -> Feasibility:
    """The peak thrust, moments, rotor thrusts and body rate that ``trajectory`` needs on an
    ideal ``vehicle`` over ``[0, duration]`` sampled every ``dt``, against its limits."""
    times = np.arange(int(np.floor(duration / dt + 1e-9)) + 1) * dt
    needs = flat_inputs(trajectory.evaluate(times), vehicle.mass, vehicle.gravity,
                        vehicle.inertia_matrix)
    if not (np.all(np.isfinite(needs.moment)) and np.all(np.isfinite(needs.thrust))):
        raise ValueError("the reference's derivatives are not finite: cannot check what it "
                         "needs of the vehicle")

    def peak(axis: str, values: np.ndarray, limit: float) -> AxisNeed:
        k = int(np.argmax(values))
        return AxisNeed(axis, float(values[k]), float(limit), float(times[k]))

    moment_limit = vehicle.moment_limit(actuation)
    rows = [peak("thrust", needs.thrust, vehicle.max_total_thrust)]
    rows += [peak(f"moment_{name}", np.abs(needs.moment[:, k]), moment_limit[k])
             for k, name in enumerate("xyz")]
    if actuation == "rotors":
        wrench = np.concatenate([needs.thrust[:, None], needs.moment], axis=1)
        rotors = wrench @ vehicle.mixer_matrix.T
        half = vehicle.max_rotor_thrust / 2
        rows.append(peak("rotors", np.abs(rotors - half).max(axis=1), half))
    rows.append(peak("body_rate", np.linalg.norm(needs.body_rate, axis=1),
                     vehicle.max_body_rate))
    return Feasibility(tuple(rows))


def refusal(name: str, vehicle: VehicleParams, actuation: str,
            feasibility: Feasibility) -> str:
    """The error message for a reference the vehicle cannot fly, naming every axis over."""
    over = [need.describe() for need in feasibility.needs if need.margin < 0]
    return (f"scenario {name!r} asks vehicle {vehicle.name!r} ({actuation} actuation) for more "
            "than its actuators give, by differential flatness without any disturbance: "
            + "; ".join(over) + ". Choose a slower reference or heading, or pass "
            "allow_infeasible=True to build it anyway.")
