"""``LoopView``: what a residual sees of its own loop, beyond one instant (issue 56).

Three optional parts, each a ``ResidualOptions`` field, written after the 16 entries every
residual sees (``observation.loop_entries`` names their columns):

- ``history_steps`` = K: the residual flown at each of the last K control steps (clipped and
  faded, as flown; 4 each) and the body-frame velocity error at the start of each of them
  (3 each), newest first, zero before a vehicle's first step. A policy that sees one
  instant cannot tell a lagged loop from a prompt one; the last K steps of what it did and
  how the error answered are the inputs in which the lag shows. K = 10 covers 0.1 s at
  100 Hz and 0.2 s at 50 Hz.
- ``thrust_path_input``: the measured thrust-path residual ``(f_z - T_c / m) / g₀``, f_z
  the accelerometer's body-z specific force (the newest IMU reading), T_c the thrust the
  autopilot commanded over the last step (``QuadrotorBatch.commanded``) and m the nominal
  mass, through a first-order low-pass at Neural-Fly's 5 Hz
  (``filters.NEURAL_FLY_FILTER_BANDWIDTH``). Whatever the thrust path does that the command
  did not ask for (the throttle map's error, the battery's sag, rotor drag, a vertical
  gust, ground effect) shows here; it is the body-vertical part of the residual force
  Neural-Fly learns from (O'Connell et al. 2022, Sci. Robot. 7: m v̇ = m g + R f_u + f, so
  Rᵀf / m = a_IMU - f_u / m), measured as a real vehicle measures it, with an IMU and its
  own command. The filter keeps the
  frame's vibration tones (v4: 30-80 Hz) out.
- ``period_input``: the control period over 10 ms (1 at 100 Hz, 2 at 50 Hz), so one policy
  flies both rates and knows which.
- ``reference_jerk_input``: the reference's jerk x⃛_d at the step (world frame, m/s³), the
  planner's, as the geometric law itself reads it for its desired body rates (Lee et al.
  2010). A lag between the command and the acceleration it gives leaves an error that grows
  with the jerk (``benchmarks/residual_room.py``: a lead of 30-50 ms on it takes 19-26 % off
  the calm and light-wind figure-8s in Benchmark v4); the acceleration the base already
  shows cannot tell the policy where the reference is going.

Nothing of the truth enters: the accelerometer and the velocity error are the measurement's
(``core.measurement``), the commanded thrust the autopilot's own, the period the loop's, the
jerk the reference's.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.filters import NEURAL_FLY_FILTER_BANDWIDTH

if TYPE_CHECKING:  # the record only: options imports this package's observation module
    from quad_dob_env.residual.options import ResidualOptions

__all__ = ["PERIOD_UNIT", "LoopView", "loop_view_size"]

# [s] the period the ``period_input`` entry is measured in: 100 Hz reads 1
PERIOD_UNIT = 0.01


def loop_view_size(options: ResidualOptions) -> int:
    """How many columns the loop view of ``options`` adds."""
    return (7 * options.history_steps + int(options.thrust_path_input)
            + int(options.period_input) + 3 * int(options.reference_jerk_input))


class LoopView:
    """The loop view's state for N vehicles flown at the period ``dt`` [s], and its
    columns."""

    def __init__(self, n: int, dt: float, options: ResidualOptions, mass: float,
                 gravity: float) -> None:
        history_steps = self.history_steps = options.history_steps
        self.thrust_path_input, self.period_input = (options.thrust_path_input,
                                                     options.period_input)
        self.reference_jerk_input = options.reference_jerk_input
        self.size = loop_view_size(options)
        self.actions = np.zeros((n, history_steps, 4))  # newest first
        self.velocity_errors = np.zeros((n, history_steps, 3))
        self.thrust_path = np.zeros(n)  # the low-passed (f_z - T_c / m) / g₀
        # the exact discrete first-order low-pass over one control step
        self.blend = 1.0 - math.exp(-NEURAL_FLY_FILTER_BANDWIDTH * dt)
        self.mass, self.gravity = mass, gravity
        self.period = dt / PERIOD_UNIT

    def restart(self, indices: NDArray[np.intp]) -> None:
        """Vehicles ``indices`` start again: no past, no thrust-path residual."""
        self.actions[indices] = 0.0
        self.velocity_errors[indices] = 0.0
        self.thrust_path[indices] = 0.0

    def advance(self, velocity_errors: NDArray, flown: NDArray, specific_force_z: NDArray,
                commanded_thrust: NDArray) -> None:
        """Once per flown step: the body-frame velocity errors (N, 3) at the step's start,
        the residual flown (N, 4), and after it the accelerometer's body-z specific force
        (N,) [m/s²] and the thrust commanded over the step (N,) [N]."""
        if self.history_steps:
            self.actions[:, 1:] = self.actions[:, :-1]
            self.actions[:, 0] = flown
            self.velocity_errors[:, 1:] = self.velocity_errors[:, :-1]
            self.velocity_errors[:, 0] = velocity_errors
        if self.thrust_path_input:
            # Neural-Fly's residual force, body z, over m g₀: (a_IMU,z - T_c / m) / g₀
            sample = (specific_force_z - commanded_thrust / self.mass) / self.gravity
            self.thrust_path += self.blend * (sample - self.thrust_path)

    def write(self, extra: NDArray[np.float32], start: int,
              reference_jerk: NDArray[np.float64]) -> None:
        """The view into ``extra``'s columns from ``start`` on; ``reference_jerk`` (N, 3)
        [m/s³] is the reference's at the step about to be flown."""
        n, k = len(extra), self.history_steps
        column = start
        if k:
            extra[:, column:column + 4 * k] = self.actions.reshape(n, 4 * k)
            column += 4 * k
            extra[:, column:column + 3 * k] = np.clip(
                self.velocity_errors.reshape(n, 3 * k), -1e3, 1e3)
            column += 3 * k
        if self.thrust_path_input:
            extra[:, column] = np.clip(self.thrust_path, -1e3, 1e3)
            column += 1
        if self.period_input:
            extra[:, column] = self.period
            column += 1
        if self.reference_jerk_input:
            extra[:, column:column + 3] = np.clip(reference_jerk, -1e3, 1e3)
