"""quad_dob_env: quadrotor environments for disturbance-rejection research.

What lives here (the order they import each other in: docs/design.md, "Layers"):
shared utilities (``validation``: input checks, ``memory``: the budget large requests are
sized against, ``linalg``: small matrix functions, ``rng``: counter-based per-vehicle noise,
``threads``: compiled loops split across cores, ``compile_notice``: what a first run
prints while the kernels compile, ``observation_entry``: the record naming an
observation entry, ``filters``: the autopilot's digital filters); ``params`` (vehicle
presets; their sources in ``vehicle_sources``),
``so3`` (rotations), ``dynamics`` (state, actuation, integrator, rotors), ``disturbances``
(forces, torques, wind, ground effect), ``trajectories``, ``flatness`` (the attitude, rates and
inputs that fly a reference), ``feasibility`` (a reference's needs against the actuators),
``variation`` (state noise, domain randomisation), ``sensing`` (sensors, delay lines and the
state estimator every policy reads through, with the ``ideal``, ``mocap`` and ``gnss-imu``
presets), ``loop_options`` (``LoopOptions``, the vehicle loop a scenario flies, one record,
resolved from its benchmark), ``scenario`` (the ``Scenario`` record, validated),
``wind_tunnel`` (Neural-Fly's
figure-8s and the tunnel's wind), ``scenarios`` (the named ones, the random-reference families
included), ``envs`` (the batched core, ``QuadrotorEnv``, ``QuadrotorVectorEnv``),
``residual`` (a base controller's command plus a policy's residual, above the envs:
``ResidualOptions``, ``ResidualCommand``, ``ResidualQuadrotorVectorEnv``) and ``wrappers``
(the residual's single-env wrapper). The package may import none of
``quad_dob_baselines``, ``quad_dob_composition`` or ``quad_dob_training``, not even at run
time (``tests/test_layering.py``): the residual ids name their composition-layer entry
points as strings.

Importing the package registers the Gymnasium ids ``QuadDOB/Hover-v1`` and
``QuadDOB/Track-v1`` (direct control), and ``QuadDOB/HoverResidual-v1`` and
``QuadDOB/TrackResidual-v1`` (a residual on top of ``base_controller``, default the
recommended ``geometric-ndob:tuned``, in wind), and ``QuadDOB/TracksResidual-v1`` (the same
on ``random-tracks``, the task distribution generalists train on); the ``-v2``, ``-v3``
and ``-v4`` ids fly the same scenarios (but the paper's wrench-actuated helix) in Benchmark
v2's, v3's and v4's loops (``benchmark``; v3's sourced values in ``benchmark_v3``, v4's in
``benchmark_v4``; the Crazyflie's loop as Crazyswarm2's logs flew it in
``crazyflie_loop``);
``gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")`` gives the native
``QuadrotorVectorEnv`` for each. The envs' version history is in ``QuadrotorEnv``'s
docstring.
"""

import gymnasium as gym

from quad_dob_env.envs import QuadrotorEnv, QuadrotorVectorEnv
from quad_dob_env.params import VEHICLES, VehicleParams, get_vehicle
from quad_dob_env.residual import DEFAULT_BASE_CONTROLLER
from quad_dob_env.scenarios import Scenario, list_scenarios, make_scenario
from quad_dob_env.sensing import SENSING_PRESETS, Measurement, SensorSuite

__version__ = "0.1.0"

ENV_IDS = {
    "QuadDOB/Hover-v1": "hover-calm",
    "QuadDOB/Track-v1": "paper-none",
    # a residual has something to learn only where there is something to reject
    "QuadDOB/HoverResidual-v1": "gusty-hover",
    "QuadDOB/TrackResidual-v1": "dryden-helix-gusts",
    # generalists: every vehicle a reference of a seeded pool, wind and physics randomised
    "QuadDOB/TracksResidual-v1": "random-tracks",
}
# Benchmark v2's loop (``benchmark="v2"``: quad_dob_env.benchmark) on the same scenarios; the
# paper's wrench-actuated helix (Track-v1's) has no v2 counterpart yet
ENV_IDS_V2 = {
    "QuadDOB/Hover-v2": "hover-calm",
    "QuadDOB/HoverResidual-v2": "gusty-hover",
    "QuadDOB/TrackResidual-v2": "dryden-helix-gusts",
    "QuadDOB/TracksResidual-v2": "random-tracks",
}

# Benchmark v3's loop (the real vehicle's lag and thrust path) on the same scenarios
ENV_IDS_V3 = {env_id.replace("-v2", "-v3"): scenario for env_id, scenario in ENV_IDS_V2.items()}
# Benchmark v4's loop (v3's with five mechanisms corrected against Neural-Fly's logs)
ENV_IDS_V4 = {env_id.replace("-v2", "-v4"): scenario for env_id, scenario in ENV_IDS_V2.items()}
BENCHMARK_OF_ID = {**{env_id: "v2" for env_id in ENV_IDS_V2},
                   **{env_id: "v3" for env_id in ENV_IDS_V3},
                   **{env_id: "v4" for env_id in ENV_IDS_V4}}
# every id this package registers, with its default scenario, in registration order
ALL_ENV_IDS = {**ENV_IDS, **ENV_IDS_V2, **ENV_IDS_V3, **ENV_IDS_V4}


def is_residual_id(env_id: str) -> bool:
    """Whether ``env_id`` is one of the residual ids (a policy's action is added to a base
    controller's command), by the naming every residual id follows."""
    return "Residual" in env_id


def _register() -> None:
    for env_id, scenario in ALL_ENV_IDS.items():
        if env_id in gym.registry:
            continue
        residual = is_residual_id(env_id)
        # the residual ids compose a controller with the simulator: they are built by the
        # composition layer, named here only as strings (docs/design.md layering)
        gym.register(id=env_id,
                     entry_point=("quad_dob_composition.envs:make_residual_env" if residual
                                  else "quad_dob_env.envs:QuadrotorEnv"),
                     vector_entry_point=("quad_dob_composition.envs:ResidualVectorEnv"
                                         if residual else "quad_dob_env.envs:QuadrotorVectorEnv"),
                     # no max_episode_steps: gym.make would wrap a TimeLimit of the
                     # default scenario's length around an env whose scenario_options
                     # make it longer; each env ends its episodes at its scenario's end
                     # and its spec reports that length (envs.limits)
                     kwargs={"scenario": scenario,
                             **({"base_controller": DEFAULT_BASE_CONTROLLER} if residual else {}),
                             **({"benchmark": BENCHMARK_OF_ID[env_id]}
                                if env_id in BENCHMARK_OF_ID else {})})


_register()

__all__ = [
    "ALL_ENV_IDS",
    "ENV_IDS",
    "ENV_IDS_V2",
    "ENV_IDS_V3",
    "ENV_IDS_V4",
    "SENSING_PRESETS",
    "VEHICLES",
    "Measurement",
    "QuadrotorEnv",
    "QuadrotorVectorEnv",
    "Scenario",
    "SensorSuite",
    "VehicleParams",
    "get_vehicle",
    "list_scenarios",
    "make_scenario",
]
