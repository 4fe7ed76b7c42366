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
from quad_dob_env.envs.kernels import (
    action_from_command_batch,
    command_from_action_batch,
    finite_values,
)
from quad_dob_env.params import VehicleParams
from quad_dob_env.validation import unknown_name_error

ACTION_MODES = ("thrust_moments", "rotor_thrusts")
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
        if action_mode == "thrust_moments":
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
        self.forward = (rotor_mode, centre, scale_up, scale_down, vehicle.allocation_matrix)
        self.inverse = (rotor_mode, centre, scale_up, scale_down, vehicle.mixer_matrix)

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
        command_from_action_batch(actions, *self.forward, thrust, moment)
        return thrust, moment


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
