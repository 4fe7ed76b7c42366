"""Gymnasium environments.

- ``core``: ``QuadrotorBatch``, the batched core (N vehicles of one scenario): actions to
  commands, physics step, observation, reward, termination, sensors, randomisation.
  Written once for every env.
- ``kernels``: its compiled per-vehicle step, sensing and sensor-noise loops.
- ``quadrotor_env``: ``QuadrotorEnv(gym.Env)``, its N = 1 view, with the tables of spaces,
  reward, start and end in its docstring.
"""

from quad_dob_env.envs.core import (
    ACTION_MODES,
    TERMINATION_REASONS,
    EpisodeLimits,
    QuadrotorBatch,
    RewardWeights,
)
from quad_dob_env.envs.quadrotor_env import QuadrotorEnv

__all__ = [
    "ACTION_MODES",
    "TERMINATION_REASONS",
    "EpisodeLimits",
    "QuadrotorBatch",
    "QuadrotorEnv",
    "RewardWeights",
]
