"""Gymnasium environments.

- ``core``: ``QuadrotorBatch``, the batched core (N vehicles of one scenario): physics
  step, observation, reward, termination, ``info``, randomisation, and the sensing stage
  (``quad_dob_env.sensing``) whose ``measurement`` every policy reads. Written once for
  every env.
- ``termination``: ``TerminationCode``, why an episode ended (the codes the step kernels
  write, the reasons ``info`` reports).
- ``observation``: ``observation_table``, every observation entry by name, unit, range and
  columns, for each layout an env can take (rotation representation, and the entries a
  residual's options append).
- ``limits``: the core's settings records (``EpisodeLimits``, ``RewardWeights``) and
  ``SpecWithEpisodeLength``, which makes both envs' ``spec`` report their episodes'
  length.
- ``actions``: ``ActionMap`` (normalised actions <-> commanded thrust and moment, both
  ways) and ``screen_actions``, the check every env face runs on its actions.
- ``step_kernels``: its compiled per-vehicle step, reset and observation loops (cut across the
  cores by ``quad_dob_env.threads``).
- ``ticks``: the pieces of a control step an inner loop flies tick by tick (the inner-rate
  estimate, ``thrust_rates``' rate law, mixer -> battery -> motors -> physics).
- ``vehicle_loop``: ``VehicleLoop``, Benchmark v2's vehicle loop for a core: the rotors'
  model, its per-episode thrust draws, the inner loop's ticks.
- ``quadrotor_env``: ``QuadrotorEnv(gym.Env)``, its N = 1 view, with the tables of spaces,
  reward, start and end in its docstring.
- ``vector_env``: ``QuadrotorVectorEnv(gymnasium.vector.VectorEnv)``, its N-vehicle view
  (next-step autoreset), the ``vector_entry_point`` of every direct id; its stages are the
  hooks the residual's vector face (``quad_dob_env.residual``, above) overrides.
- ``info``: the layout of every vehicle's ``info`` numbers and the pass that writes them.
- ``rendering``: ``FlightRenderer``, the frames of ``render_mode="rgb_array"``/``"human"``.

May import the simulator's folders and modules below it (the order: docs/design.md,
"Layers"); never ``residual`` or ``wrappers``, which build on it, nor ``quad_dob_baselines``,
``quad_dob_composition`` or ``quad_dob_training``.
"""

from quad_dob_env.envs.actions import ACTION_MODES, ActionMap
from quad_dob_env.envs.core import EpisodeLimits, QuadrotorBatch, RewardWeights
from quad_dob_env.envs.observation import ObservationEntry, observation_table
from quad_dob_env.envs.quadrotor_env import QuadrotorEnv
from quad_dob_env.envs.termination import TERMINATION_REASONS, TIME_LIMIT, TerminationCode
from quad_dob_env.envs.vector_env import QuadrotorVectorEnv

__all__ = [
    "ACTION_MODES",
    "TERMINATION_REASONS",
    "TIME_LIMIT",
    "ActionMap",
    "EpisodeLimits",
    "ObservationEntry",
    "QuadrotorBatch",
    "QuadrotorEnv",
    "QuadrotorVectorEnv",
    "RewardWeights",
    "TerminationCode",
    "observation_table",
]
