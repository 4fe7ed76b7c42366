"""When an episode ends, and what the reward weighs: the core's two settings records, the
time limit an env's spec reports, and how many vehicles fit the memory budget."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from gymnasium.envs.registration import EnvSpec

from quad_dob_env.memory import check_memory
from quad_dob_env.validation import as_finite

# What one vehicle costs the core and the env stacks over it, rounded up from tracemalloc
# (about 1.1 KiB in the core and 3.4 KiB with a residual base at N = 4,096; sensing's delay
# lines are checked on their own)
VEHICLE_BYTES = 8 * 1024


def check_vehicle_memory(vehicles: int, option: str = "num_envs") -> None:
    """Refuse, before anything is allocated, a batch of vehicles past the memory budget."""
    check_memory(vehicles * VEHICLE_BYTES, f"{vehicles:,} vehicles",
                 f"fly fewer vehicles at once ({option})")


@dataclass(frozen=True)
class EpisodeLimits:
    """When an episode ends early (``terminated``); all documented in ``QuadrotorEnv``."""

    max_position_error: float = 5.0  # [m] from the reference
    max_tilt: float = np.pi / 2  # [rad] between body z and world z
    max_body_rate: float = 35.0  # [rad/s], any axis

    def __post_init__(self) -> None:
        as_finite(self.max_position_error, "max_position_error", 0.0, strictly=True)
        as_finite(self.max_tilt, "max_tilt", 0.0, strictly=True)
        if self.max_tilt > np.pi:
            raise ValueError(f"max_tilt must be <= pi, got {self.max_tilt}")
        as_finite(self.max_body_rate, "max_body_rate", 0.0, strictly=True)

    def kernel_limits(self, floor_height: float | None) -> KernelLimits:
        """The record the compiled step checks each vehicle against (``step_kernels``)."""
        return KernelLimits(
            max_position_error=float(self.max_position_error),
            cos_max_tilt=float(np.cos(self.max_tilt)), max_body_rate=float(self.max_body_rate),
            has_floor=floor_height is not None,
            floor_height=0.0 if floor_height is None else float(floor_height))


class KernelLimits(NamedTuple):
    """``EpisodeLimits`` as the step kernels take them: the tilt as its cosine (body z's
    world-z component, R[2, 2]), the scenario's floor."""

    max_position_error: float  # [m]
    cos_max_tilt: float
    max_body_rate: float  # [rad/s]
    has_floor: bool
    floor_height: float  # [m], 0 without a floor


@dataclass(frozen=True)
class RewardWeights:
    """``reward = exp(-|e_x| / position_scale) - effort_weight * mean(action²)``."""

    position_scale: float = 0.25  # [m]
    effort_weight: float = 0.01

    def __post_init__(self) -> None:
        as_finite(self.position_scale, "reward position_scale", 0.0, strictly=True)
        as_finite(self.effort_weight, "reward effort_weight", 0.0)


class SpecWithEpisodeLength:
    """Mixed into both envs (before Gymnasium's base class): ``spec``, as ``gym.make`` /
    ``gym.make_vec`` set it, reports the episodes' own length in ``max_episode_steps``.

    The ids register no ``max_episode_steps``: ``gym.make`` would wrap every env in a
    ``TimeLimit`` of the default scenario's length before it could see that
    ``scenario_options`` changed ``dt`` or ``duration``, cutting such episodes short. The env
    ends its episodes itself at its scenario's end (``core.episode_steps``) and reports that
    length here, so ``TimeAwareObservation`` and other clients that read
    ``env.spec.max_episode_steps`` see the limit that really applies (a ``TimeLimit`` the
    user asked for reports its own)."""

    core: Any  # the env's QuadrotorBatch
    _spec: EnvSpec | None = None

    @property
    def spec(self) -> EnvSpec | None:
        return self._spec

    @spec.setter
    def spec(self, spec: EnvSpec | None) -> None:
        if spec is not None and spec.max_episode_steps is None:
            spec = dataclasses.replace(spec, max_episode_steps=int(self.core.episode_steps))
        self._spec = spec


def episode_steps(scenario_steps: int, max_episode_steps: int | None) -> int:
    """Steps after which an episode is truncated: the scenario's, or ``max_episode_steps``
    (``make_vec(..., max_episode_steps=N)``) if sooner."""
    if max_episode_steps is None:
        return scenario_steps
    if (not isinstance(max_episode_steps, (int, np.integer))
            or isinstance(max_episode_steps, bool) or max_episode_steps < 1):
        raise ValueError(f"max_episode_steps must be an integer >= 1 or None, got "
                         f"{max_episode_steps!r}")
    return min(scenario_steps, int(max_episode_steps))
