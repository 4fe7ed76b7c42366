"""The Lee controller as the Crazyflie's firmware flies it (IMRCLab crazyflie-firmware,
branch ``unify-firmware``, ``src/modules/src/controller_lee.c``), the law Crazyswarm2's
flight logs flew (issue 59), as a named variant of ``geometric``.

The firmware's law, with e_p = p_d - p and e_v = v_d - v (its sign), per axis ∘:

- ``F_d = a_d + g e3 + Kpos_D ∘ e_v + Kpos_P ∘ e_p + Kpos_I ∘ ∫e_p``, ``f = m F_d · R e3``;
- ``Rd`` from ``F_d`` and the reference's yaw (Lee's construction);
- ``M = -KR ∘ eR - Kw ∘ eΩ - KI ∘ ∫eR + Ω × JΩ``, both integrals advanced by forward
  Euler at the law's rate *before* they are used, and neither clamped.

Term by term onto ``geometric`` (``GeometricLaw``), for the mass ``m`` the firmware was
told (``ctrlLee.mass``, not the vehicle's true one):

| firmware | here |
|---|---|
| ``Kpos_P``, ``Kpos_D`` | ``kx_per_mass``, ``kv_per_mass`` (so kx = m Kpos_P) |
| ``Kpos_I ∘ ∫e_p`` | the force estimate ``d̂x = -m Kpos_I ∘ ∫e_p`` (F subtracts it) |
| ``KR`` | ``kR = KR + KI dt``: the attitude integral's newest term, ``KI dt eR`` |
| ``KI ∘ ∫eR`` up to the last step | the torque estimate ``d̂Ω`` (M subtracts it) |
| ``Kw`` | ``kΩ`` |
| no ``-J(hat(Ω) RᵀRd Ωd - RᵀRd Ω̇d)`` | ``rotation_feedforward = 0`` |
| Ωd from the reference's jerk | ``rate_feedback = 0`` |

The firmware makes Ωd from the reference's jerk alone, ``hw = m / f (j - (z_d · j) z_d)``:
``rate_feedback = 0`` drops the errors' terms that Lee's law differentiates F with. Three
differences are kept and stated: the firmware divides by ``f = m F_d · R e3`` where the
flatness divides by ``|F|`` (equal to second order in the tilt from Rd); its Ωd about z is
the reference's yaw rate times ``z_d · e3``, where Lee's construction adds b3's turn about
the heading (a few mrad/s on these flights); and its errors are clamped at ±100
(``Kpos_P_limit``, ``Kpos_D_limit``), which no flight here reaches. The law
runs entirely at the control rate (the firmware's ``ATTITUDE_RATE``, 500 Hz): it has no
inner law of its own.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_baselines.geometric import GeometricController
from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.trajectories import Reference
from quad_dob_env.validation import as_finite

Triple = tuple[float, float, float]


@dataclass(frozen=True)
class FirmwareLeeGains:
    """The firmware's ``ctrlLee`` parameters, in its own names and units (per axis x, y, z):
    position gains per mass [1/s², 1/s, 1/s³], attitude gains [N m / rad, N m s / rad,
    N m / (rad s)], and the mass [kg] the firmware was told. The defaults are Crazyswarm2's
    logs 182 and 184 (``info*.yaml``); 178 sets ``kpos_i`` to 32 on every axis, 183 to 20,
    and 201-206 tell the mass 0.0419 kg."""

    kpos_p: Triple = (17.0, 17.0, 17.0)
    kpos_d: Triple = (7.0, 7.0, 7.0)
    kpos_i: Triple = (0.0, 0.0, 10.0)
    kr: Triple = (0.009, 0.009, 0.009)
    ki: Triple = (0.05, 0.05, 0.05)
    kw: Triple = (0.00125, 0.00125, 0.0025)
    mass: float = 0.032

    def __post_init__(self) -> None:
        for name in ("kpos_p", "kpos_d", "kpos_i", "kr", "ki", "kw"):
            values = getattr(self, name)
            if not isinstance(values, (tuple, list)) or len(values) != 3:
                raise ValueError(f"FirmwareLeeGains.{name} must be three numbers (x, y, z), "
                                 f"got {values!r}")
            strictly = name not in ("kpos_i", "ki")  # an integral may be switched off
            object.__setattr__(self, name, tuple(
                as_finite(value, f"FirmwareLeeGains.{name}[{axis}]", 0.0, strictly=strictly)
                for axis, value in enumerate(values)))
        object.__setattr__(self, "mass", as_finite(self.mass, "FirmwareLeeGains.mass", 0.0,
                                                   strictly=True))

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, Any]) -> FirmwareLeeGains:
        """The gains from the firmware's parameter names (``Kpos_Px`` ... ``Kw_z``,
        ``mass``), as Crazyswarm2's ``info*.yaml`` and ``crazyflies.yaml`` write them."""
        prefixes = {"kpos_p": "Kpos_P", "kpos_d": "Kpos_D", "kpos_i": "Kpos_I", "kr": "KR_",
                    "ki": "KI_", "kw": "Kw_"}
        missing = [f"{prefix}{axis}" for prefix in prefixes.values() for axis in "xyz"
                   if f"{prefix}{axis}" not in parameters] + (
            [] if "mass" in parameters else ["mass"])
        if missing:
            raise ValueError("the firmware's Lee parameters lack " + ", ".join(missing))
        return cls(**{name: tuple(float(parameters[f"{prefix}{axis}"]) for axis in "xyz")
                      for name, prefix in prefixes.items()}, mass=float(parameters["mass"]))


class FirmwareLeeController(GeometricController):
    """The Crazyflie firmware's Lee law (module docstring) on ``geometric_law``; ``gains``
    a ``FirmwareLeeGains`` or a dict of its fields."""

    name = "crazyflie-lee"
    has_inner_law = False  # the firmware runs position and attitude in one law at 500 Hz

    def __init__(self, gains: FirmwareLeeGains | Mapping[str, Any] | None = None) -> None:
        if gains is None:
            gains = FirmwareLeeGains()
        elif isinstance(gains, Mapping):
            gains = FirmwareLeeGains(**gains)
        elif not isinstance(gains, FirmwareLeeGains):
            raise ValueError("FirmwareLeeController takes a FirmwareLeeGains or a dict of its "
                             f"fields, got {type(gains).__name__}")
        self.firmware_gains = gains
        # kR here is the firmware's KR; reset adds the attitude integral's newest term
        super().__init__(kx_per_mass=gains.kpos_p, kv_per_mass=gains.kpos_d, kR=gains.kr,
                         kOmega=gains.kw)
        self.name = "crazyflie-lee"

    def refusal(self, dt: float, actuation: str,
                vehicle: VehicleParams | None = None) -> str | None:
        """The firmware's gains are absolute (N m per rad for the attitude) and come with the
        mass it was told: a vehicle more than twice or less than half that mass is another
        class, whose flight these gains say nothing about."""
        problem = super().refusal(dt, actuation, vehicle)
        told = self.firmware_gains.mass
        if problem is None and vehicle is not None and not 0.5 <= vehicle.mass / told <= 2.0:
            problem = (f"{self.name} flies the Crazyflie firmware's gains, set for a vehicle "
                       f"of about {told:g} kg (their told mass); {vehicle.name!r} weighs "
                       f"{vehicle.mass:g} kg: fly vehicle crazyflie-2.1, or give gains "
                       "(FirmwareLeeGains) for this vehicle")
        return problem

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        problem = self.refusal(dt, actuation, vehicle)
        if problem is not None:
            raise ValueError(problem)
        told = replace(vehicle, mass=self.firmware_gains.mass)  # the firmware's ctrlLee.mass
        super().reset(num_vehicles, told, dt, indices, actuation)
        if indices is None:
            ki = np.asarray(self.firmware_gains.ki)
            # M = -KR eR - KI (∫eR up to the last step + dt eR): the newest term rides on kR
            self._geometric_law = self._geometric_law._replace(
                k_attitude=tuple((self.gains["kR"] + ki * dt).tolist()),
                rotation_feedforward=0.0, rate_feedback=0.0)
            self.position_integral = np.zeros((num_vehicles, 3))  # ∫(p_d - p) dt
            self.attitude_integral = np.zeros((num_vehicles, 3))  # ∫eR dt
            self._position_before = np.zeros((num_vehicles, 3))
            self._attitude_before = np.zeros((num_vehicles, 3))
            self._due = np.ones(num_vehicles, dtype=bool)
        else:
            for integral in (self.position_integral, self.attitude_integral,
                             self._position_before, self._attitude_before):
                integral[indices] = 0.0
            self._due[indices] = True

    def compute(self, time: NDArray, state: VehicleState, reference: Reference,
                acceleration_correction: NDArray | None = None) -> tuple[NDArray, NDArray]:
        gains, due = self.firmware_gains, self._due
        # each integral as it stood after the last flown step; computing again before the
        # next step (a residual env's second command) starts from it again
        self._position_before[due] = self.position_integral[due]
        self._attitude_before[due] = self.attitude_integral[due]
        # ∫e_p advanced before use (controller_lee.c: i_error_pos += dt pos_e)
        self.position_integral = (self._position_before
                                  + self.dt * (reference.position - state.position))
        self._force_estimate = -gains.mass * np.asarray(gains.kpos_i) * self.position_integral
        self._torque_estimate = np.asarray(gains.ki) * self._attitude_before
        thrust, moment = super().compute(time, state, reference, acceleration_correction)
        # i_error_att += dt eR, with the eR this step's moment used
        self.attitude_integral = (self._attitude_before
                                  + self.dt * self.diagnostics["attitude_error"])
        self._due[:] = False
        return thrust, moment

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        self._due[:] = True

    def _estimates(self, state: VehicleState) -> tuple[NDArray, NDArray]:
        return self._force_estimate, self._torque_estimate

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, **{key: list(value) if isinstance(value, tuple) else value
                                      for key, value in asdict(self.firmware_gains).items()}}
