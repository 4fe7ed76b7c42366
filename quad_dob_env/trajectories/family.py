"""A family of references: every vehicle flies one member, drawn at its reset.

``TrajectoryFamily(members)`` is what a scenario's ``trajectory`` may be instead of one
``Trajectory``: the core tabulates every member, and at each reset a vehicle draws the index
of its member from its own generator (before anything else it draws), so the same seed gives
the same reference and the vehicles of one batch fly different ones.

``random_references(seed, count, ...)`` builds a seeded pool of smooth random references with
closed-form derivatives to snap: horizontal circles and figure eights of random size, speed,
centre, direction and heading, random sums of sinusoids on the three axes (smooth random
paths), and hovers; ``families=`` picks which kinds, so some can be held out of training.
The draws are bounded so the references stay within what the vehicle's actuators give; the
scenario built on a family checks every member (``feasibility``) and refuses any that does
not fit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from quad_dob_env.trajectories.base import Trajectory
from quad_dob_env.trajectories.library import Harmonic, Hover, Lemniscate
from quad_dob_env.validation import unknown_name_error

REFERENCE_KINDS = ("circle", "lemniscate", "sinusoids", "hover")
# the speeds and accelerations the draws keep within: the v1 helix's own peak acceleration
# is 5.9 m/s² and its speed 1.3 m/s, which the feasibility check accepts with margin
MAX_ACCELERATION = 4.0  # m/s²
MAX_SPEED = 2.0  # m/s


class TrajectoryFamily:
    """``members``, one of which each vehicle flies (drawn at its reset)."""

    def __init__(self, members: Sequence[Trajectory], kinds: Sequence[str] | None = None) -> None:
        self.members = tuple(members)
        if not self.members or not all(isinstance(m, Trajectory) for m in self.members):
            raise ValueError("TrajectoryFamily needs one or more Trajectory members")
        self.kinds = tuple(kinds) if kinds is not None else ("member",) * len(self.members)
        if len(self.kinds) != len(self.members):
            raise ValueError(f"TrajectoryFamily: {len(self.kinds)} kinds for "
                             f"{len(self.members)} members")


def random_references(seed: int, count: int, kinds: Sequence[str] = REFERENCE_KINDS,
                      altitude: tuple[float, float] = (1.5, 2.5)) -> TrajectoryFamily:
    """``count`` references drawn from ``seed``, cycling through ``kinds``."""
    for kind in kinds:
        if kind not in REFERENCE_KINDS:
            raise unknown_name_error("reference kind", kind, REFERENCE_KINDS)
    if count < 1:
        raise ValueError(f"random_references needs count >= 1, got {count}")
    rng = np.random.default_rng(seed)
    members, names = [], []
    for index in range(count):
        kind = kinds[index % len(kinds)]
        centre = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(*altitude))
        yaw = rng.uniform(-math.pi, math.pi)
        members.append(_draw(kind, rng, centre, yaw))
        names.append(kind)
    return TrajectoryFamily(members, names)


def _draw(kind: str, rng: np.random.Generator, centre: tuple[float, float, float],
          yaw: float) -> Trajectory:
    if kind == "hover":
        return Hover(centre, yaw=yaw)
    if kind == "circle":
        radius = rng.uniform(0.3, 1.5)
        # ω from a speed and an acceleration both within bounds: a = r ω², v = r ω
        omega = min(math.sqrt(rng.uniform(0.5, MAX_ACCELERATION) / radius), MAX_SPEED / radius)
        turn = rng.choice([-1.0, 1.0])  # counter-clockwise or clockwise
        phase = rng.uniform(-math.pi, math.pi)
        return Harmonic(offset=centre, yaw=yaw, terms=[
            (0, radius, omega, phase + math.pi / 2), (1, turn * radius, omega, phase)])
    if kind == "lemniscate":
        amplitude = rng.uniform(0.4, 1.5)
        # the y term at 2ω has the larger acceleration: (a/2)(2ω)² = 2 a ω²
        omega = min(math.sqrt(rng.uniform(0.5, MAX_ACCELERATION) / (2 * amplitude)),
                    MAX_SPEED / (1.5 * amplitude))
        return Lemniscate(centre, amplitude, 2 * math.pi / omega, yaw=yaw)
    # sinusoids: two terms per axis (one on z, smaller), random frequencies and phases,
    # amplitudes scaled so each axis's acceleration bound holds term by term
    terms = []
    for axis, share in ((0, 0.5), (1, 0.5), (2, 0.25)):
        for _ in range(2):
            omega = rng.uniform(0.4, 2.0)
            amplitude = min(rng.uniform(0.1, 0.6), share * MAX_ACCELERATION / omega**2,
                            share * MAX_SPEED / omega)
            terms.append((axis, amplitude, omega, rng.uniform(-math.pi, math.pi)))
    return Harmonic(offset=centre, terms=terms, yaw=yaw)
