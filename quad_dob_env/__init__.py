"""quad_dob_env: quadrotor environments for disturbance-rejection research.

Layers, each importing only from those above it (DESIGN.md):
``validation``, ``linalg``, ``rng`` (shared utilities: input checks, small matrix
functions, counter-based per-vehicle noise), ``params`` (vehicle presets), ``so3``
(rotations), ``dynamics`` (state, actuation, integrator), ``disturbances`` (forces,
torques, wind, ground effect), ``trajectories``, ``scenarios``, ``envs``.

Importing the package registers the Gymnasium ids ``QuadDOB/Hover-v0`` and
``QuadDOB/Track-v0``.
"""

import gymnasium as gym

from quad_dob_env.envs import QuadrotorEnv
from quad_dob_env.params import VEHICLES, VehicleParams, get_vehicle
from quad_dob_env.scenarios import Scenario, list_scenarios, make_scenario

__version__ = "0.1.0"

ENV_IDS = {
    "QuadDOB/Hover-v0": "hover-calm",
    "QuadDOB/Track-v0": "paper-none",
}


def _register() -> None:
    for env_id, scenario in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="quad_dob_env.envs:QuadrotorEnv",
                         kwargs={"scenario": scenario})


_register()

__all__ = [
    "ENV_IDS",
    "VEHICLES",
    "QuadrotorEnv",
    "Scenario",
    "VehicleParams",
    "get_vehicle",
    "list_scenarios",
    "make_scenario",
]
