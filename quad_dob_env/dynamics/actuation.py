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


def as_floats(vector: ArrayLike) -> tuple[float, ...]:
    """A constant vector as the compiled kernels take it: a tuple of floats."""
    return tuple(float(value) for value in np.asarray(vector, dtype=float).reshape(-1))


def as_rows(matrix: ArrayLike) -> tuple[tuple[float, ...], ...]:
    """A constant matrix as the compiled kernels take it: a tuple of rows, each a tuple of
    floats, read as ``matrix[row][column]``. A tuple carries no reference count: an array
    handed to an inlined per-vehicle function is counted in and out at every call, and on
    two threads that count is a cache line both cores write (docs/speed.md)."""
    return tuple(as_floats(row) for row in np.asarray(matrix, dtype=float))


class ActuatorArrays(NamedTuple):
    """The actuators as the compiled step reads them (``Actuator.kernel_record``): the
    mixer's limits, the maps from their output to the wrench and the rotors (constants, as
    tuples: ``as_rows``), and each vehicle's output now (the lag is each vehicle's,
    ``rotors.RotorDraws``)."""

    code: int  # ACTUATION_CODES
    mixer: tuple  # 4 rows of 4: [f, M] -> rotor thrusts
    max_rotor_thrust: float  # [N]
    max_total_thrust: float  # [N]
    moment_limit: tuple  # 3 [N m]
    to_wrench: tuple  # 4 rows of 4: output -> [f, Mx, My, Mz]
    to_rotors: tuple  # 4 rows of 4: output -> rotor thrusts
    output: NDArray  # (N, 4) rotor thrusts, the wrench, or rotor speeds (speed motors)


class Mixing(NamedTuple):
    """``ActuatorArrays``' constants, without the batch's ``output`` array: what the
    per-vehicle functions take (``mixing_of``), numbers and tuples only."""

    code: int
    mixer: tuple
    max_rotor_thrust: float
    max_total_thrust: float
    moment_limit: tuple
    to_wrench: tuple
    to_rotors: tuple


@njit(cache=True, inline="always")
def mixing_of(actuator):
    """``actuator``'s (an ``ActuatorArrays``) ``Mixing``."""
    return Mixing(actuator.code, actuator.mixer, actuator.max_rotor_thrust,
                  actuator.max_total_thrust, actuator.moment_limit, actuator.to_wrench,
                  actuator.to_rotors)


@njit(cache=True, inline="always")
def _mat4_vec(matrix, a, b, c, d):
    """A 4 x 4 matrix (``as_rows``) times (a, b, c, d)."""
    return (matrix[0][0] * a + matrix[0][1] * b + matrix[0][2] * c + matrix[0][3] * d,
            matrix[1][0] * a + matrix[1][1] * b + matrix[1][2] * c + matrix[1][3] * d,
            matrix[2][0] * a + matrix[2][1] * b + matrix[2][2] * c + matrix[2][3] * d,
            matrix[3][0] * a + matrix[3][1] * b + matrix[3][2] * c + matrix[3][3] * d)


@njit(cache=True)
def actuate_vehicle(thrust, moment, actuation_code, mixer, max_rotor_thrust, max_total_thrust,
                    moment_limit):
    """Commanded (f, M) -> the actuator command the vehicle can follow, and whether a limit
    was hit.

    ``rotors`` (code 0): four rotor thrusts in [0, max], mixed with yaw at the lowest
    priority, as flight controllers do: thrust, roll and pitch are mixed and clipped first,
    then the yaw moment is scaled down to the headroom left, because yaw comes from rotor
    drag and asking for more than that would starve the others.
    ``wrench`` (code 1): thrust and each moment clipped to their limits.
    """
    if actuation_code == 0:
        base = _mat4_vec(mixer, thrust, moment[0], moment[1], 0.0)
        yaw = (mixer[0][3] * moment[2], mixer[1][3] * moment[2], mixer[2][3] * moment[2],
               mixer[3][3] * moment[2])
        clipped_base = (min(max(base[0], 0.0), max_rotor_thrust),
                        min(max(base[1], 0.0), max_rotor_thrust),
                        min(max(base[2], 0.0), max_rotor_thrust),
                        min(max(base[3], 0.0), max_rotor_thrust))
        share = 1.0  # of the yaw request that fits
        for k in range(4):
            if yaw[k] > 0.0:
                share = min(share, (max_rotor_thrust - clipped_base[k]) / yaw[k])
            elif yaw[k] < 0.0:
                share = min(share, -clipped_base[k] / yaw[k])
        share = max(share, 0.0)
        rotors = (clipped_base[0] + share * yaw[0], clipped_base[1] + share * yaw[1],
                  clipped_base[2] + share * yaw[2], clipped_base[3] + share * yaw[3])
        return rotors, share < 1.0 or clipped_base != base
    command = (min(max(thrust, 0.0), max_total_thrust),
               min(max(moment[0], -moment_limit[0]), moment_limit[0]),
               min(max(moment[1], -moment_limit[1]), moment_limit[1]),
               min(max(moment[2], -moment_limit[2]), moment_limit[2]))
    return command, command != (thrust, moment[0], moment[1], moment[2])


@njit(cache=True, inline="always")
def store_applied(i, output, to_wrench, to_rotors, out_thrust, out_moment, out_rotors):
    """Write the wrench and rotor thrusts of actuator output ``output`` for vehicle i."""
    wrench = _mat4_vec(to_wrench, output[0], output[1], output[2], output[3])
    rotors = _mat4_vec(to_rotors, output[0], output[1], output[2], output[3])
    out_thrust[i] = wrench[0]  # straight-line: a loop here would count each array per call
    out_moment[i, 0], out_moment[i, 1], out_moment[i, 2] = wrench[1], wrench[2], wrench[3]
    out_rotors[i, 0], out_rotors[i, 1] = rotors[0], rotors[1]
    out_rotors[i, 2], out_rotors[i, 3] = rotors[2], rotors[3]


@njit(cache=True)
def _actuate_batch(thrust, moment, actuation_code, mixer, max_rotor_thrust, max_total_thrust,
                   moment_limit, to_wrench, to_rotors, out_thrust, out_moment, out_rotors,
                   out_saturated):
    for i in range(thrust.shape[0]):
        output, out_saturated[i] = actuate_vehicle(
            thrust[i], (moment[i, 0], moment[i, 1], moment[i, 2]), actuation_code, mixer,
            max_rotor_thrust, max_total_thrust, moment_limit)
        store_applied(i, output, to_wrench, to_rotors, out_thrust, out_moment, out_rotors)


class Actuator:
    """Turns a commanded thrust and moment into what the vehicle can produce.

    ``rotors``: the command is mixed to four rotor thrusts in ``[0, max_rotor_thrust]``,
    yaw at the lowest priority (thrust, roll and pitch first, then the yaw that still
    fits), and mapped back through the allocation matrix, so the saturation is the physical
    one (yaw authority is the rotors' drag torque).
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

    @property
    def to_wrench(self) -> NDArray[np.float64]:
        """Maps the actuator output (rotor thrusts, or the wrench) to [f, Mx, My, Mz]."""
        return self.params.allocation_matrix if self.code == 0 else np.eye(4)

    @property
    def to_rotors(self) -> NDArray[np.float64]:
        """Maps the actuator output to the four rotor thrusts."""
        return np.eye(4) if self.code == 0 else self.params.mixer_matrix

    def hover_output(self) -> NDArray[np.float64]:
        """The actuator output that holds the vehicle's weight, level."""
        return np.linalg.solve(self.to_wrench, [self.params.hover_thrust, 0.0, 0.0, 0.0])

    def kernel_arguments(self) -> tuple:
        """The arguments ``actuate_vehicle`` takes after the command."""
        p = self.params
        return (self.code, as_rows(p.mixer_matrix), float(p.max_rotor_thrust),
                float(p.max_total_thrust), as_floats(self.moment_limit))

    def kernel_record(self, output: NDArray) -> ActuatorArrays:
        """The record the compiled step reads, with the batch's ``output`` array (N, 4),
        written in place."""
        p = self.params
        return ActuatorArrays(
            code=self.code, mixer=as_rows(p.mixer_matrix),
            max_rotor_thrust=float(p.max_rotor_thrust),
            max_total_thrust=float(p.max_total_thrust), moment_limit=as_floats(self.moment_limit),
            to_wrench=as_rows(self.to_wrench), to_rotors=as_rows(self.to_rotors), output=output)

    def apply(self, thrust: ArrayLike, moment: ArrayLike) -> AppliedCommand:
        """What an instantaneous actuator produces for the commanded thrust and moment."""
        thrust = np.ascontiguousarray(thrust, dtype=float).reshape(-1)
        n = thrust.shape[0]
        moment = np.ascontiguousarray(np.broadcast_to(np.asarray(moment, float), (n, 3)))
        out = AppliedCommand(np.empty(n), np.empty((n, 3)), np.empty((n, 4)),
                             np.empty(n, dtype=np.bool_))
        _actuate_batch(thrust, moment, *self.kernel_arguments(), as_rows(self.to_wrench),
                       as_rows(self.to_rotors), *out)
        return out
