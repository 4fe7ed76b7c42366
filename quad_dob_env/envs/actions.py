"""What an env's actions are: normalised in [-1, 1]^4, mapped to commanded thrust and moment.

- ``ActionMap``: the piecewise-linear map (action 0 at hover) for an action mode, both ways;
  the compiled per-vehicle step uses its ``forward`` tuple, the residual and the reference
  policies its inverse.
- ``screen_actions``: the check every env face runs on the actions it is given (shape,
  numbers, NaN or inf: raise, or end those episodes).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.dynamics import Actuator
from quad_dob_env.dynamics.actuation import as_floats, as_rows
from quad_dob_env.envs.step_kernels import (
    action_from_command_batch,
    command_from_action_batch,
    finite_values,
)
from quad_dob_env.params import VehicleParams
from quad_dob_env.validation import unknown_name_error

ACTION_MODES = ("thrust_moments", "rotor_thrusts", "thrust_rates")
# thrust_rates: the inner rate loop's bandwidth [1/s] (a fifth of the 100 Hz control rate,
# so one step's correction never overshoots) and the largest body rate it is asked for
RATE_GAIN = 20.0
MAX_RATE_COMMAND = 4.0  # [rad/s]
INVALID_ACTION_MODES = ("raise", "terminate")


class ActionMap:
    """Normalised actions <-> commanded (thrust, moment) for ``action_mode``:
    [-1, 0, 1] -> [0, hover, max] per entry (total thrust and the actuator's moment limits,
    or each rotor's thrust). Actions beyond [-1, 1] are clipped.

    ``forward`` is ``(rotor_mode, centre, scale_up, scale_down, allocation)``, what the
    compiled step takes; ``inverse`` is the same with the mixer in place of the allocation.
    """

    def __init__(self, vehicle: VehicleParams, actuator: Actuator,
                 action_mode: str = "thrust_moments") -> None:
        if action_mode not in ACTION_MODES:
            raise unknown_name_error("action_mode", action_mode, ACTION_MODES)
        self.action_mode = action_mode
        # thrust_rates flies through thrust_moments: the rate loop turns rates into moments
        self.rate_loop = RateLoop(actuator.moment_limit) if action_mode == "thrust_rates" else None
        if action_mode in ("thrust_moments", "thrust_rates"):
            moment = actuator.moment_limit
            centre = np.array([vehicle.hover_thrust, 0.0, 0.0, 0.0])
            scale_up = np.concatenate([[vehicle.max_total_thrust - vehicle.hover_thrust], moment])
            scale_down = np.concatenate([[vehicle.hover_thrust], moment])
        else:
            per_rotor = vehicle.hover_thrust / 4
            centre = np.full(4, per_rotor)
            scale_up = np.full(4, vehicle.max_rotor_thrust - per_rotor)
            scale_down = np.full(4, per_rotor)
        rotor_mode = action_mode == "rotor_thrusts"
        # constants as tuples (``as_rows``): they count no references in the kernels
        shape = (as_floats(centre), as_floats(scale_up), as_floats(scale_down))
        self.forward = (rotor_mode, *shape, as_rows(vehicle.allocation_matrix))
        self.inverse = (rotor_mode, *shape, as_rows(vehicle.mixer_matrix))

    def flown(self, actions: NDArray, angular_velocity: NDArray, inertia: NDArray) -> NDArray:
        """The actions the compiled step takes: ``actions`` themselves, or with
        ``thrust_rates`` the thrust-and-moment actions its rate loop commands now."""
        if self.rate_loop is None:
            return actions
        return self.rate_loop.moment_actions(actions, angular_velocity, inertia)

    def to_actions(self, thrust: NDArray, moment: NDArray) -> NDArray[np.float64]:
        """The normalised actions (N, 4) that command ``thrust`` (N,) and ``moment`` (N, 3),
        clipped to [-1, 1] (so beyond the limits they saturate)."""
        thrust = np.ascontiguousarray(thrust, dtype=np.float64).reshape(-1)
        moment = np.ascontiguousarray(moment, dtype=np.float64).reshape(-1, 3)
        actions = np.empty((len(thrust), 4))
        action_from_command_batch(thrust, moment, self.inverse, actions)
        return actions

    def to_command(self, actions: NDArray) -> tuple[NDArray, NDArray]:
        """Thrust (N,) and moment (N, 3) that normalised ``actions`` (N, 4) command, before
        the actuators' limits."""
        actions = np.ascontiguousarray(actions, dtype=np.float64).reshape(-1, 4)
        thrust, moment = np.empty(len(actions)), np.empty((len(actions), 3))
        command_from_action_batch(actions, self.forward, thrust, moment)
        return thrust, moment


class RateLoop:
    """Collective thrust and body rates -> thrust and moments, the inner loop rotorpy and
    "Learning to Fly in Seconds" give their policies: action entries 1-3 ask for body
    rates ``ω_cmd = a · MAX_RATE_COMMAND``, and each control step commands
    ``M = J k_ω (ω_cmd - ω) + ω × J ω`` (Lee et al. 2010, eq. 16's rate and gyroscopic
    terms), as the moment actions the core flies; entry 0 stays the collective thrust."""

    def __init__(self, moment_limit: NDArray, gain: float = RATE_GAIN,
                 max_rate: float = MAX_RATE_COMMAND) -> None:
        self.moment_limit, self.gain, self.max_rate = np.asarray(moment_limit), gain, max_rate

    def moment_actions(self, actions: NDArray, angular_velocity: NDArray,
                       inertia: NDArray) -> NDArray[np.float64]:
        """(N, 4) thrust-and-rate actions as thrust-and-moment actions, for body rates
        ``angular_velocity`` (N, 3) and inertias (N, 3, 3)."""
        commanded = np.clip(actions[:, 1:], -1.0, 1.0) * self.max_rate
        spin = np.einsum("nij,nj->ni", inertia, angular_velocity)
        moment = (self.gain * np.einsum("nij,nj->ni", inertia, commanded - angular_velocity)
                  + np.cross(angular_velocity, spin))
        out = np.array(actions, dtype=np.float64)
        out[:, 1:] = moment / self.moment_limit
        return out


_NO_ROWS = np.zeros(0, dtype=np.intp)


def screen_actions(actions: object, shape: tuple[int, ...], invalid_actions: str = "raise"
                   ) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Actions as float64 of ``shape`` ((4,) or (N, 4)) and the rows that were NaN or
    infinite. ``invalid_actions="raise"`` raises ValueError on them; ``"terminate"`` sets
    those rows to 0 (hover) and returns their indices, so the caller ends those episodes.
    A wrong shape or a non-numeric action always raises. Values outside [-1, 1] pass: the
    core clips them."""
    try:
        array = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"actions must be numeric with shape {shape}, got "
                         f"{actions!r}") from None
    if array.shape != shape:
        raise ValueError(f"actions must have shape {shape}, got {array.shape}")
    if finite_values(array.reshape(-1)):  # the usual case, kept cheap: one compiled pass
        return array, _NO_ROWS
    if invalid_actions not in INVALID_ACTION_MODES:
        raise unknown_name_error("invalid_actions", invalid_actions, INVALID_ACTION_MODES)
    array = array.copy()  # the caller's array is not ours to change
    rows = array.reshape(-1, 4)
    bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
    if bad.size and invalid_actions == "raise":
        where = "" if len(shape) == 1 else f"envs {bad[:10].tolist()} got "
        raise ValueError(f"actions must be finite; {where}{rows[bad[0]].tolist()} (allowed: "
                         "[-1, 1], values outside are clipped; invalid_actions='terminate' "
                         "ends the episode instead)")
    rows[bad] = 0.0
    return array, bad
