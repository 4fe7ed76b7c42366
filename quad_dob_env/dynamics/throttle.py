"""The throttle between the autopilot and the rotors (Benchmark v3): what thrust a throttle
gives, what the autopilot believes it gives, and the battery under both.

An offboard controller of the Neural-Fly kind sends a collective thrust normalised by its
estimate of the hover throttle, ``T_sp = t̂_h f / (m̂ g)``; the autopilot mixes it with the
moments into per-rotor outputs and writes them to the ESCs. Per rotor, with its believed
thrust ``T_c`` from the mixer (the vehicle's nominal hover thrust per rotor ``T̂_h`` at
``t̂_h``):

- the throttle the autopilot asks for: ``t = t̂_h T_c / T̂_h``, then PX4's thrust model
  inverted, ``u = (-(1 - κ_ap) + sqrt((1 - κ_ap)² + 4 κ_ap t)) / (2 κ_ap)``
  (``THR_MDL_FAC`` = κ_ap; 0, PX4's default, is ``u = t``), held in [0, 1]: 1 is the
  ESC's full-scale signal (``PWM_MAX``), the ceiling;
- the thrust the rotor gives at ``u``: ``T = T_full ((1 - κ) u + κ u²)``, PX4's model form
  with the propulsion class's own κ, where ``T_full`` is what the pack gives at full
  throttle now. The hover throttle is a thrust setpoint, as PX4's ``MPC_THR_HOVER`` and
  Neural-Fly's logged ``hover_throttle`` are: the true one, ``t_h``, is the setpoint whose
  output ``u_h`` (κ_ap's inversion) holds the true weight,
  ``T_full ((1 - κ) u_h + κ u_h²) = m g / 4``;
- the battery: ``t_h = t_h0 + r t`` climbs as the pack drains (``t_h0`` and ``r`` drawn per
  episode: one pack among many, a flight's drift), and the autopilot's estimate from the
  pack's voltage is ``t̂_h = t_h (1 + ε)``, ε drawn per episode.

Where κ_ap = κ, ε = 0 and the believed weight is the truth, the thrust is what was asked
for below the ceiling; the default
κ_ap = 0 under a quadratic rotor (κ > 0) gives ``∂T/∂T_c = ((1 - κ) + 2 κ t_h) /
((1 - κ) + κ t_h)`` at hover: more thrust per newton asked than the autopilot believes,
a force that follows the commanded acceleration. Imports nothing above ``validation``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit

from quad_dob_env.validation import as_finite


def _pair(value: object, name: str, low: float, high: float) -> tuple[float, float]:
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise ValueError(f"ThrottleMap.{name} must be a (low, high) pair, got {value!r}")
    pair = tuple(as_finite(v, f"ThrottleMap.{name}") for v in value)
    if not low <= pair[0] <= pair[1] <= high:
        raise ValueError(f"ThrottleMap.{name} needs {low:g} <= low <= high <= {high:g}, got "
                         f"{value!r}")
    return pair


@dataclass(frozen=True)
class ThrottleMap:
    """The throttle-to-thrust map and the battery under it, per episode (seeded draws).

    - ``thrust_model_factor`` κ: the rotors' true ``T / T_full = (1 - κ) u + κ u²``;
    - ``autopilot_thrust_model_factor`` κ_ap: PX4's ``THR_MDL_FAC`` as the autopilot flies
      it (0: it believes thrust linear in throttle);
    - ``hover_throttle`` (low, high): the true hover throttle at the start, drawn uniformly
      (one pack among many);
    - ``hover_throttle_drift`` (low, high) [1/s]: its climb through the flight, drawn
      uniformly, in [0, 0.01];
    - ``hover_estimate_error`` e: the autopilot's estimate is the truth times ``1 + ε``,
      ε uniform in [-e, e].
    """

    thrust_model_factor: float
    hover_throttle: tuple[float, float]
    hover_throttle_drift: tuple[float, float] = (0.0, 0.0)
    hover_estimate_error: float = 0.0
    autopilot_thrust_model_factor: float = 0.0

    def __post_init__(self) -> None:
        for name in ("thrust_model_factor", "autopilot_thrust_model_factor"):
            value = as_finite(getattr(self, name), f"ThrottleMap.{name}")
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"ThrottleMap.{name} is PX4's THR_MDL_FAC, in [0, 1], got "
                                 f"{value!r}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "hover_throttle",
                           _pair(self.hover_throttle, "hover_throttle", 1e-3, 1.0))
        # a draining pack's hover throttle only climbs (and stays above 0, so a rotor's
        # full-throttle thrust stays finite)
        object.__setattr__(self, "hover_throttle_drift",
                           _pair(self.hover_throttle_drift, "hover_throttle_drift", 0.0, 0.01))
        error = as_finite(self.hover_estimate_error, "ThrottleMap.hover_estimate_error", 0.0)
        if error >= 1.0:
            raise ValueError("ThrottleMap.hover_estimate_error is a relative bound below 1, got "
                             f"{error!r}")
        object.__setattr__(self, "hover_estimate_error", error)


@njit(cache=True, inline="always")
def throttle_of(thrust_fraction, model_factor):
    """The output u whose modelled thrust ``(1 - κ) u + κ u²`` is ``thrust_fraction``
    (PX4's inversion of THR_MDL_FAC), before the ceiling."""
    if model_factor <= 0.0:
        return thrust_fraction
    linear = 1.0 - model_factor
    return (-linear + math.sqrt(linear * linear + 4.0 * model_factor * max(thrust_fraction, 0.0))
            ) / (2.0 * model_factor)


@njit(cache=True, inline="always")
def thrust_fraction_of(throttle, model_factor):
    """``(1 - κ) u + κ u²``: the share of full thrust at output u."""
    return (1.0 - model_factor) * throttle + model_factor * throttle * throttle


@njit(cache=True, inline="always")
def throttle_state(true_hover, estimate_factor, true_hover_rotor_thrust, believed_hover_rotor,
                   model_factor, autopilot_factor):
    """This instant's (throttle per believed newton ``t̂_h / T̂_h``, full-throttle thrust
    ``T_full``) from the true hover throttle ``t_h`` now: the output that hovers,
    ``u_h = throttle_of(t_h, κ_ap)``, gives the true weight."""
    hover_output = throttle_of(true_hover, autopilot_factor)
    full = true_hover_rotor_thrust / thrust_fraction_of(hover_output, model_factor)
    return true_hover * estimate_factor / believed_hover_rotor, full


@njit(cache=True, inline="always")
def rotor_thrusts_of(thrusts, per_newton, full, model_factor, autopilot_factor):
    """The true rotor thrusts for the mixer's believed ``thrusts`` (at least 0) and whether
    any output was held at the ceiling."""
    t0, h0 = _rotor_thrust_of(thrusts[0], per_newton, full, model_factor, autopilot_factor)
    t1, h1 = _rotor_thrust_of(thrusts[1], per_newton, full, model_factor, autopilot_factor)
    t2, h2 = _rotor_thrust_of(thrusts[2], per_newton, full, model_factor, autopilot_factor)
    t3, h3 = _rotor_thrust_of(thrusts[3], per_newton, full, model_factor, autopilot_factor)
    return (t0, t1, t2, t3), h0 or h1 or h2 or h3


@njit(cache=True, inline="always")
def _rotor_thrust_of(thrust, per_newton, full, model_factor, autopilot_factor):
    """One rotor's true thrust for its believed ``thrust``, and whether its output was held
    at the ceiling."""
    u = throttle_of(per_newton * thrust, autopilot_factor)
    if u > 1.0:
        return full * thrust_fraction_of(1.0, model_factor), True
    return full * thrust_fraction_of(u, model_factor), False
