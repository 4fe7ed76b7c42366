"""A family of references: every vehicle flies one member, drawn at its reset.

``TrajectoryFamily(members)`` is what a scenario's ``trajectory`` may be instead of one
``Trajectory``: the core tabulates every member, and at each reset a vehicle draws the index
of its member from its own generator (before anything else it draws), so the same seed gives
the same reference and the vehicles of one batch fly different ones.

``random_references(seed, count, ...)`` builds a seeded pool of smooth random references with
closed-form derivatives to snap: horizontal circles and figure eights of random size, speed,
centre, direction and heading, random sums of sinusoids on the three axes (smooth random
paths), helices (a circle in a vertical plane of random direction, radius and rate, drifting
along its axis, as the v1 helix does), take-offs to a hover and landings (from and to
``LANDING_HEIGHT`` above the floor, through ground effect where the scenario has it),
hovers, and hops (rest-to-rest moves through random 3-D waypoints, a kind no training family
holds); ``kinds=`` picks which, so some can be held out of training.
The draws are bounded so the references stay within what the vehicle's actuators give; the
scenario built on a family checks every member (``feasibility``) and refuses any that does
not fit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from quad_dob_env.trajectories.base import Trajectory
from quad_dob_env.trajectories.library import (
    Harmonic,
    Hover,
    Lemniscate,
    TakeoffHoverLanding,
    WaypointHops,
)
from quad_dob_env.validation import unknown_name_error

REFERENCE_KINDS = ("circle", "lemniscate", "sinusoids", "hover", "helix", "landing", "hops")
LANDING_HEIGHT = 0.08  # m: where take-offs start and landings end, as in the v1 scenarios
# the speeds and accelerations the draws keep within: the v1 helix's own peak acceleration
# is 5.9 m/s² and its speed 1.3 m/s, which the feasibility check accepts with margin
MAX_ACCELERATION = 4.0  # m/s²
MAX_SPEED = 2.0  # m/s
# helices turn in a vertical plane, where the thrust itself must swing by r ω² (the v1
# helix's 5.9 m/s² nearly unloads the rotors at its top): up to 6 m/s² there
MAX_VERTICAL_ACCELERATION = 6.0  # m/s²
MAX_DRIFT = 0.6  # m/s, a helix's speed along its axis (the v1 helix: 0.4)
# and at most the v1 helix's rate, π rad/s: its snap r ω⁴ is what the rotors' moment
# range must follow (4.1 rad/s at 0.33 m asked for three times the yaw moment there is)
MAX_HELIX_RATE = math.pi  # rad/s
# a hops reference: 3-5 hops of 0.3-1.2 m, each held 0.3-1.5 s, within the first 9.5 s
# (an episode is 10 s); the septic smoothstep's peaks per unit length and time
HOP_COUNTS = (3, 5)
HOP_HEIGHTS = (1.0, 3.0)  # [m] where the waypoints may lie
SMOOTHSTEP_PEAK_SPEED = 35.0 / 16.0
SMOOTHSTEP_PEAK_ACCELERATION = 7.5132  # max of s'' on [0, 1], at tau = (5 - sqrt 5)/10
MAX_REDRAWS = 100  # draws of one member that ``accept`` may refuse before it is an error


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
                      altitude: tuple[float, float] = (1.5, 2.5),
                      accept: Callable[[Trajectory], bool] | None = None) -> TrajectoryFamily:
    """``count`` references drawn from ``seed``, cycling through ``kinds``; a draw that
    ``accept`` refuses is drawn again (from the same generator, so still seeded): a
    scenario passes the vehicle's feasibility margin, which this layer does not know."""
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
        member = _draw(kind, rng, centre, yaw)
        for _ in range(MAX_REDRAWS):
            if accept is None or accept(member):
                break
            member = _draw(kind, rng, centre, yaw)
        else:
            raise ValueError(f"random_references: {MAX_REDRAWS} draws of a {kind} in a row "
                             "were refused; loosen the bounds or the acceptance test")
        members.append(member)
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
    if kind == "landing":
        climb, hover, descent = (rng.uniform(2.0, 3.5), rng.uniform(1.0, 3.0),
                                 rng.uniform(2.0, 3.5))
        return TakeoffHoverLanding(xy=centre[:2], start_height=LANDING_HEIGHT,
                                   hover_height=rng.uniform(0.6, 1.5), end_height=LANDING_HEIGHT,
                                   climb_time=climb, hover_time=hover, descent_time=descent,
                                   yaw=yaw)
    if kind == "helix":
        radius = rng.uniform(0.3, 0.8)
        drift = rng.uniform(0.0, MAX_DRIFT)
        omega = min(math.sqrt(rng.uniform(2.0, MAX_VERTICAL_ACCELERATION) / radius),
                    (MAX_SPEED - drift) / radius, MAX_HELIX_RATE)
        # it drifts along its heading ``yaw`` (as in v1): a heading across the plane swings
        # the thrust about a tilted body axis and asks for a yaw moment beyond the rotors'
        # (a draw with a random heading needed 145 % of it)
        across = (-math.sin(yaw), math.cos(yaw))  # the plane's horizontal direction
        # started within 45° of the top, as the v1 helix starts at it: there the thrust
        # must fall to m (g - r ω²) while the motors still spin at hover, the hardest start
        phase = rng.uniform(-math.pi / 4, math.pi / 4)
        return Harmonic(offset=centre, yaw=yaw,
                        drift=(drift * math.cos(yaw), drift * math.sin(yaw), 0.0),
                        terms=[(0, radius * across[0], omega, phase),
                               (1, radius * across[1], omega, phase),
                               (2, radius, omega, phase + math.pi / 2)])
    if kind == "hops":
        return _hops(rng, centre, yaw)
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


def _hops(rng: np.random.Generator, centre: tuple[float, float, float],
          yaw: float) -> WaypointHops:
    """3-5 hops from ``centre``, each 0.3-1.2 m in a random direction (its vertical part
    halved, the waypoints kept within ``HOP_HEIGHTS``), as fast as a drawn acceleration and
    speed within the bounds allow."""
    points, starts, durations = [np.array(centre)], [], []
    time = rng.uniform(0.3, 1.5)
    for _ in range(rng.integers(HOP_COUNTS[0], HOP_COUNTS[1] + 1)):
        direction = rng.normal(size=3)
        direction[2] *= 0.5
        step = rng.uniform(0.3, 1.2) * direction / np.linalg.norm(direction)
        target = points[-1] + step
        target[2] = np.clip(target[2], *HOP_HEIGHTS)  # clear of the floor and the ceiling
        step = target - points[-1]
        length = max(float(np.linalg.norm(step)), 1e-3)
        acceleration = rng.uniform(1.0, MAX_ACCELERATION)
        duration = max(math.sqrt(SMOOTHSTEP_PEAK_ACCELERATION * length / acceleration),
                       SMOOTHSTEP_PEAK_SPEED * length / MAX_SPEED)
        if time + duration > 9.5:
            break
        points.append(target)
        starts.append(time)
        durations.append(duration)
        time += duration + rng.uniform(0.3, 1.5)
    if not starts:  # the first hop did not fit: one short one
        points.append(points[0] + np.array([0.3, 0.0, 0.0]))
        starts.append(0.5)
        durations.append(2.0)
    return WaypointHops(np.array(points), starts, durations, yaw=yaw)
