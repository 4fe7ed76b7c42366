"""The controller interface: a template every baseline follows (docs/design.md principle 2).

A controller maps (time, state, reference) to collective thrust and body moments for the
whole batch, and is then told what the actuators actually applied, so internal states
(observer, integrators) advance with what was applied rather than the request. ``reset``
starts fresh episodes for some or all vehicles.

The ``state`` a controller is given is the env's measurement
(``quad_dob_env.sensing.Measurement``, a ``VehicleState``): the estimate of position,
velocity, attitude and rates (the true state with ideal sensing) plus the raw
``gyroscope``, ``accelerometer`` and ``rotor_speeds`` readings, for methods that use them.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.dynamics import VehicleState
from quad_dob_env.params import VehicleParams
from quad_dob_env.trajectories import Reference
from quad_dob_env.validation import as_finite

E3 = np.array([0.0, 0.0, 1.0])


def validated_gains(owner: str, defaults: dict[str, float], given: dict[str, float],
                    strictly_positive: bool) -> dict[str, float]:
    """``defaults`` updated with ``given``; an unknown name or a bad value raises ValueError."""
    unknown = sorted(set(given) - set(defaults))
    if unknown:
        raise ValueError(f"unknown {owner} gain {unknown[0]!r}; valid: " + ", ".join(defaults))
    return {key: as_finite(given.get(key, value), f"{owner}.{key}", 0.0,
                           strictly=strictly_positive) for key, value in defaults.items()}


class Controller:
    """Batched controller template. Subclasses implement ``compute``; stateful ones extend
    ``reset`` and ``applied``. ``diagnostics`` holds (N, ...) arrays of the last step, such
    as ``desired_rotation``, ``attitude_error`` and disturbance estimates."""

    name = "controller"
    # whether ``compute`` takes ``acceleration_correction`` (N, 3), an outer loop's addition
    # to the reference acceleration (what an acceleration residual flies through)
    accepts_acceleration_correction = False
    # whether ``inner_law`` gives an attitude law an inner loop can run (else, with an inner
    # loop, the command ``compute`` gives is held over the control step)
    has_inner_law = False
    # [s] the inner loop's period this controller flies with (``use_inner_loop``), or None
    inner_period: float | None = None
    # the ``gain_sets.GainSet`` make_controller built it with (None: built directly)
    gain_set: Any = None
    # a user's controller (``plugins``): the gains ``quad-dob tune`` searches, name ->
    # default (its start), and those of them that are an estimator's bandwidth [rad/s],
    # capped and tie-broken as the observers' rates are; the built-in ones are tuned by
    # ``training/tuning/tune.py``'s own tables
    tunable_gains: ClassVar[dict[str, float]] = {}
    estimator_bandwidths: ClassVar[tuple[str, ...]] = ()
    # what it can fly: the actuations it commands (``quad_dob_env.dynamics.ACTUATIONS``), and
    # the one control step it runs at [s] (None: any); ``reset`` refuses anything else
    actuations: ClassVar[tuple[str, ...]] = ("rotors", "wrench")
    control_period: ClassVar[float | None] = None

    def __init__(self) -> None:
        self.vehicle: VehicleParams | None = None
        self.dt = 0.01
        self.n = 0
        self.actuation = "rotors"
        self.diagnostics: dict[str, NDArray] = {}

    def reset(self, num_vehicles: int, vehicle: VehicleParams, dt: float,
              indices: NDArray[np.intp] | None = None, actuation: str = "rotors") -> None:
        """Start episodes: all vehicles when ``indices`` is None (re-sizing the batch).
        ``actuation`` names how the vehicle turns a command into thrust and moments
        (``quad_dob_env.dynamics.Actuator``), for controllers that model their limits."""
        problem = self.refusal(dt, actuation, vehicle)
        if problem is not None:
            raise ValueError(problem)
        if indices is None:
            self.n, self.vehicle, self.dt = int(num_vehicles), vehicle, float(dt)
            self.actuation = actuation

    def refusal(self, dt: float, actuation: str,
                vehicle: VehicleParams | None = None) -> str | None:
        """Why this controller cannot fly a control step of ``dt`` s with ``actuation``
        (``actuations``, ``control_period``), or ``vehicle`` (a subclass's own reason: gains
        for one vehicle class), or None when it can."""
        if actuation not in self.actuations:
            return (f"{self.name} flies the actuation(s) {', '.join(self.actuations)}; this "
                    f"scenario's is {actuation!r}")
        if self.control_period is not None and abs(dt - self.control_period) > 1e-9:
            return (f"{self.name} runs every {self.control_period:g} s; this scenario's control "
                    f"step is {dt:g} s: fly it at dt={self.control_period:g} (quad-dob evaluate "
                    f"--scenario-option dt={self.control_period:g})")
        return None

    def compute(self, time: NDArray, state: VehicleState,
                reference: Reference) -> tuple[NDArray, NDArray]:
        """Thrust (N,) and body moment (N, 3) for the batch."""
        raise NotImplementedError

    def applied(self, state: VehicleState, thrust: NDArray, moment: NDArray) -> None:
        """What the actuators produced for the last ``compute`` (after saturation), with the
        state that command was computed from."""

    def use_inner_loop(self, period: float | None) -> None:
        """Fly with an inner loop of ``period`` s (None: without one). Then ``compute`` is
        the outer part, leaving ``desired_force``, ``desired_rotation``,
        ``desired_angular_velocity`` and ``desired_angular_acceleration`` in
        ``diagnostics``, and the loop runs ``inner_law()`` at every tick
        (``quad_dob_baselines.inner``). Called by whatever composes the controller with an
        env, before its ``reset``."""
        self.inner_period = period

    def inner_law(self) -> Any:
        """The ``quad_dob_baselines.inner.InnerLaw`` for the last ``compute``."""
        raise NotImplementedError(f"{self.name} has no attitude law for an inner loop")

    def describe(self) -> dict[str, Any]:
        """Name and gains, for reports."""
        return {"name": self.name}
