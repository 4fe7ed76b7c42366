"""Rotor allocation and limits: a commanded thrust and moment become what the rotors make."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from quad_dob_env.params import ACTUATIONS, Actuation, VehicleParams
from quad_dob_env.validation import unknown_name_error


class AppliedCommand(NamedTuple):
    """What the rotors actually produced after saturation."""

    thrust: NDArray[np.float64]  # (N,) collective thrust [N]
    moment: NDArray[np.float64]  # (N, 3) body moment [N m]
    rotor_thrusts: NDArray[np.float64]  # (N, 4) [N]
    saturated: NDArray[np.bool_]  # (N,) any limit was hit


ACTUATION_CODES = {"rotors": 0, "wrench": 1}


@njit(cache=True, inline="always")
def _mat4_vec(matrix, a, b, c, d):
    return (matrix[0, 0] * a + matrix[0, 1] * b + matrix[0, 2] * c + matrix[0, 3] * d,
            matrix[1, 0] * a + matrix[1, 1] * b + matrix[1, 2] * c + matrix[1, 3] * d,
            matrix[2, 0] * a + matrix[2, 1] * b + matrix[2, 2] * c + matrix[2, 3] * d,
            matrix[3, 0] * a + matrix[3, 1] * b + matrix[3, 2] * c + matrix[3, 3] * d)


@njit(cache=True)
def actuate_vehicle(thrust, moment, actuation_code, allocation, mixer, max_rotor_thrust,
                    max_total_thrust, moment_limit):
    """Commanded (f, M) -> applied (f, M), rotor thrusts, and whether a limit was hit."""
    if actuation_code == 0:
        requested = _mat4_vec(mixer, thrust, moment[0], moment[1], moment[2])
        saturated = False
        clipped = [0.0, 0.0, 0.0, 0.0]
        for k in range(4):
            clipped[k] = min(max(requested[k], 0.0), max_rotor_thrust)
            saturated = saturated or clipped[k] != requested[k]
        rotors = (clipped[0], clipped[1], clipped[2], clipped[3])
        applied = _mat4_vec(allocation, rotors[0], rotors[1], rotors[2], rotors[3])
        return applied[0], (applied[1], applied[2], applied[3]), rotors, saturated
    f = min(max(thrust, 0.0), max_total_thrust)
    m = (min(max(moment[0], -moment_limit[0]), moment_limit[0]),
         min(max(moment[1], -moment_limit[1]), moment_limit[1]),
         min(max(moment[2], -moment_limit[2]), moment_limit[2]))
    saturated = f != thrust or m[0] != moment[0] or m[1] != moment[1] or m[2] != moment[2]
    return f, m, _mat4_vec(mixer, f, m[0], m[1], m[2]), saturated


@njit(cache=True, inline="always")
def store_applied(i, thrust, moment, rotors, saturated, out_thrust, out_moment, out_rotors,
                  out_saturated):
    """Write vehicle i's applied command into the batch arrays."""
    out_thrust[i] = thrust
    out_saturated[i] = saturated
    for k in range(3):
        out_moment[i, k] = moment[k]
    for k in range(4):
        out_rotors[i, k] = rotors[k]


@njit(cache=True)
def _actuate_batch(thrust, moment, actuation_code, allocation, mixer, max_rotor_thrust,
                   max_total_thrust, moment_limit, out_thrust, out_moment, out_rotors,
                   out_saturated):
    for i in range(thrust.shape[0]):
        f, m, rotors, saturated = actuate_vehicle(
            thrust[i], (moment[i, 0], moment[i, 1], moment[i, 2]), actuation_code, allocation,
            mixer, max_rotor_thrust, max_total_thrust, moment_limit)
        store_applied(i, f, m, rotors, saturated, out_thrust, out_moment, out_rotors,
                      out_saturated)


class Actuator:
    """Turns a commanded thrust and moment into what the vehicle can produce.

    ``rotors``: the command is mixed to four rotor thrusts, each clipped to
    ``[0, max_rotor_thrust]``, and mapped back through the allocation matrix, so the
    saturation is the physical one (yaw authority is the rotors' drag torque).
    ``wrench``: thrust is clipped to ``[0, 4 max_rotor_thrust]`` and each moment to
    ``moment_limit("wrench")``, as in the paper's model where moments are applied directly.
    """

    def __init__(self, params: VehicleParams, actuation: Actuation = "rotors") -> None:
        if actuation not in ACTUATIONS:
            raise unknown_name_error("actuation", actuation, ACTUATIONS)
        self.params = params
        self.actuation = actuation
        self.code = ACTUATION_CODES[actuation]
        self.moment_limit = params.moment_limit(actuation)

    def kernel_arguments(self) -> tuple:
        """The arguments ``actuate_vehicle`` takes after the command."""
        p = self.params
        return (self.code, p.allocation_matrix, p.mixer_matrix, float(p.max_rotor_thrust),
                float(p.max_total_thrust), self.moment_limit)

    def apply(self, thrust: ArrayLike, moment: ArrayLike) -> AppliedCommand:
        thrust = np.ascontiguousarray(thrust, dtype=float).reshape(-1)
        n = thrust.shape[0]
        moment = np.ascontiguousarray(np.broadcast_to(np.asarray(moment, float), (n, 3)))
        out = AppliedCommand(np.empty(n), np.empty((n, 3)), np.empty((n, 4)),
                             np.empty(n, dtype=np.bool_))
        _actuate_batch(thrust, moment, *self.kernel_arguments(), *out)
        return out
