"""The disturbance interface: a template for every model of what pushes the vehicle.

A model gives, for each of N vehicles and K sample times, three channels: the external
force d_x (world frame, N), the torque d_Ω (body frame, N m) and the wind velocity w (world
frame, m/s; it acts through the vehicle's drag on v - w). Models with random parameters draw
them in ``resample`` from each vehicle's own generator, so every vehicle's disturbance
follows from its seed alone.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.validation import as_finite


class Disturbance:
    """External force and torque as functions of time, for a batch of vehicles.

    Subclasses implement ``evaluate``; those with random parameters override ``bind``
    (allocate per-vehicle storage) and ``resample`` (draw new values at reset).
    """

    #: True when the model draws per-vehicle parameters; the env then evaluates it every
    #: step. Models that are a function of time alone are tabulated once per episode grid.
    is_random: bool = False
    #: Whether ``evaluate`` reads its times, and which of (force, torque, wind) it writes:
    #: the env skips the rest for random models each step.
    uses_time: bool = True
    channels: tuple[bool, bool, bool] = (True, True, True)
    #: True when the model depends on the vehicle's true state (a payload on a cable): the
    #: env then calls ``follow`` each step before ``add_to``.
    follows_vehicle: bool = False

    def bind(self, num_vehicles: int, dt: float) -> None:
        """Prepare per-vehicle storage for a batch of this size stepped every ``dt`` s."""

    def resample(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        """Draw fresh random parameters for vehicles ``indices``, ``rngs[j]`` for the j-th."""

    def follow(self, position: NDArray[np.float64], velocity: NDArray[np.float64],
               vehicle_mass: NDArray[np.float64] | None = None) -> None:
        """Take the true vehicle position and velocity (N, 3, world frame) at the start of
        the control step, and each vehicle's true mass (N,; None: vehicles moved by hand,
        which nothing pushes back). The env calls it once a step, before ``add_to``, and
        only when ``follows_vehicle``; a model that depends on the vehicle's state advances
        its own state here."""

    def evaluate(self, times: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        """Force, torque and wind velocity, each (N, K, 3), at ``times`` (N, K).

        Random models are evaluated once per control step, in order, at that step's grid."""
        raise NotImplementedError

    def sampled_parameters(self, index: int) -> dict[str, float]:
        """What ``resample`` drew for vehicle ``index`` (reported in the env's reset info)."""
        return {}

    def add_to(self, times: NDArray[np.float64], force: NDArray, torque: NDArray,
               wind: NDArray) -> None:
        """Add this model's channels at ``times`` into the (N, K, 3) arrays, in place. The env
        calls this for random models each step (``times`` is None for models that declare
        ``uses_time = False``); override it to skip the temporaries."""
        for total, channel in zip((force, torque, wind), self.evaluate(times), strict=True):
            total += channel

    def __add__(self, other: Disturbance) -> Sum:
        if not isinstance(other, Disturbance):
            return NotImplemented
        return Sum([self, other])

    def during(self, start: float, end: float) -> Disturbance:
        """This disturbance, switched on only for ``start <= t < end``."""
        return Window(self, start, end)


class Sum(Disturbance):
    """The sum of several disturbances; ``a + b + c`` builds one flat Sum."""

    def __init__(self, parts: Sequence[Disturbance]) -> None:
        flat: list[Disturbance] = []
        for part in parts:
            if not isinstance(part, Disturbance):
                raise ValueError(f"Sum takes Disturbance models, got {type(part).__name__}")
            flat.extend(part.parts if isinstance(part, Sum) else [part])
        self.parts = flat
        self.is_random = any(part.is_random for part in flat)
        self.uses_time = any(part.uses_time for part in flat)
        self.channels = tuple(any(part.channels[k] for part in flat) for k in range(3))
        self.follows_vehicle = any(part.follows_vehicle for part in flat)

    def bind(self, num_vehicles: int, dt: float) -> None:
        for part in self.parts:
            part.bind(num_vehicles, dt)

    def resample(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        for part in self.parts:
            part.resample(indices, rngs)

    def follow(self, position: NDArray[np.float64], velocity: NDArray[np.float64],
               vehicle_mass: NDArray[np.float64] | None = None) -> None:
        for part in self.parts:
            if part.follows_vehicle:
                part.follow(position, velocity, vehicle_mass)

    def add_to(self, times: NDArray[np.float64], force: NDArray, torque: NDArray,
               wind: NDArray) -> None:
        for part in self.parts:
            part.add_to(times, force, torque, wind)

    def sampled_parameters(self, index: int) -> dict[str, float]:
        sampled: dict[str, float] = {}
        for part in self.parts:
            sampled.update(part.sampled_parameters(index))
        return sampled

    def evaluate(self, times: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        channels = [channel.copy() for channel in self.parts[0].evaluate(times)]
        for part in self.parts[1:]:
            for total, channel in zip(channels, part.evaluate(times), strict=True):
                total += channel
        return tuple(channels)

    def __repr__(self) -> str:
        return " + ".join(repr(part) for part in self.parts)


def split_by_randomness(disturbance: Disturbance | None, n: int, dt: float
                        ) -> tuple[list[Disturbance], Disturbance | None]:
    """The parts of ``disturbance`` that depend on time alone (to tabulate once), and its
    random ones as one disturbance (None if there are none): copies, bound to ``n`` vehicles
    at ``dt``, because their per-vehicle parameters live in the object."""
    parts = [] if disturbance is None else (
        disturbance.parts if isinstance(disturbance, Sum) else [disturbance])
    random = [copy.deepcopy(p) for p in parts if p.is_random]
    combined = None if not random else (random[0] if len(random) == 1 else Sum(random))
    if combined is not None:
        combined.bind(n, dt)
    return [p for p in parts if not p.is_random], combined


class Window(Disturbance):
    """``inner`` switched on for ``start <= t < end`` and off otherwise (a step on and off)."""

    def __init__(self, inner: Disturbance, start: float, end: float) -> None:
        if not isinstance(inner, Disturbance):
            raise ValueError(f"Window wraps a Disturbance, got {type(inner).__name__}")
        self.inner = inner
        self.is_random = inner.is_random
        self.channels = inner.channels
        self.follows_vehicle = inner.follows_vehicle
        self.start = as_finite(start, "Window.start")
        self.end = as_finite(end, "Window.end")
        if self.end <= self.start:
            raise ValueError(f"Window.end must be > start, got start={start}, end={end}")

    def bind(self, num_vehicles: int, dt: float) -> None:
        self.inner.bind(num_vehicles, dt)

    def resample(self, indices: NDArray[np.intp], rngs: Sequence[np.random.Generator]) -> None:
        self.inner.resample(indices, rngs)

    def follow(self, position: NDArray[np.float64], velocity: NDArray[np.float64],
               vehicle_mass: NDArray[np.float64] | None = None) -> None:
        # the inner model keeps following outside the window: its state runs on regardless
        self.inner.follow(position, velocity, vehicle_mass)

    def sampled_parameters(self, index: int) -> dict[str, float]:
        return self.inner.sampled_parameters(index)

    def evaluate(self, times: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        active = ((times >= self.start) & (times < self.end))[..., None]
        return tuple(channel * active for channel in self.inner.evaluate(times))

    def __repr__(self) -> str:
        return f"{self.inner!r}.during({self.start}, {self.end})"
