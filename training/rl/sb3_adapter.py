"""stable-baselines3 from an env id: ``make_sb3_vec_env("QuadDOB/HoverResidual-v3", n)``.

SB3 takes neither a Gymnasium vector env (``gym.make_vec(id, n,
vectorization_mode="vector_entry_point")`` is refused as "not a Gymnasium environment") nor
an id's options on its own: ``QuadrotorSB3VecEnv(n, scenario)`` builds the direct v1 env
unless it is also given ``base_controller=`` and ``benchmark=``. ``make_sb3_vec_env`` reads
what the id builds (``gym.spec(env_id).kwargs``: its scenario, base controller and
benchmark), lays the caller's overrides over it, and builds that as a
``QuadrotorSB3VecEnv``, so that::

    from stable_baselines3 import PPO
    from quad_dob_training.rl import make_sb3_vec_env

    model = PPO("MlpPolicy", make_sb3_vec_env("QuadDOB/HoverResidual-v3", 16, seed=0))
    model.learn(100_000)
    model.save("hover_v3.zip")  # quad-dob evaluate --policies ppo:hover_v3.zip
                                #   --env QuadDOB/HoverResidual-v3

trains on exactly the vehicles the id's vector env flies (same observations and rewards
for the same seeds and actions, up to the first episode's end: SB3 resets a finished
vehicle in the step that ends it, Gymnasium's vector env in the next), and the saved zip
is evaluated with the same id. The env comes behind SB3's ``VecMonitor``, so ``learn``
logs each finished episode's return and length (``ep_rew_mean``, ``ep_len_mean``); its
``venv`` is the ``QuadrotorSB3VecEnv``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

import quad_dob_env
from quad_dob_env import is_residual_id


def env_ids() -> list[str]:
    """The project's registered ids (v1, v2 and v3), in registration order."""
    return list(quad_dob_env.ALL_ENV_IDS)


def id_benchmark(env_id: str) -> str:
    """The benchmark ``env_id`` flies: v2's and v3's ids name theirs, v1's none."""
    id_kwargs(env_id)  # an unknown id is refused, naming the project's
    return quad_dob_env.BENCHMARK_OF_ID.get(env_id, "v1")


def id_kwargs(env_id: str) -> dict[str, Any]:
    """``gym.spec(env_id).kwargs`` of one of the project's ids, copied; any other id is
    refused, naming the project's."""
    from quad_dob_env.validation import unknown_name_error

    if not isinstance(env_id, str) or env_id not in env_ids():
        raise unknown_name_error("env id", env_id, env_ids())
    return dict(gym.spec(env_id).kwargs)


def make_sb3_vec_env(env_id: str, n: int, **overrides: Any) -> Any:
    """``n`` vehicles of ``env_id`` as a stable-baselines3 ``VecEnv``
    (``QuadrotorSB3VecEnv`` behind ``VecMonitor``): the id's own options
    (``gym.spec(env_id).kwargs``: scenario, base controller, benchmark) with ``overrides``
    laid over them (``seed``, ``scenario_options``, residual options, the training-only
    ``loop_randomization``; any keyword of ``QuadrotorSB3VecEnv``). Vehicle i is seeded
    ``seed + i``, as ``gym.make_vec(env_id, n, vectorization_mode="vector_entry_point")
    .reset(seed=seed)`` seeds it, so both fly the same episodes."""
    from quad_dob_training.rl.vec_env import QuadrotorSB3VecEnv

    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"make_sb3_vec_env: n is the number of vehicles, a whole number "
                         f">= 1, got {n!r}")
    kwargs = {**id_kwargs(env_id), **overrides}
    if is_residual_id(env_id) and kwargs.get("base_controller") is None:
        raise ValueError(f"{env_id} is a residual id: base_controller must name a controller "
                         "(such as 'geometric-ndob:tuned'), not None; for direct control "
                         "use a direct id (" + ", ".join(
                             i for i in env_ids() if not is_residual_id(i)) + ")")
    if not is_residual_id(env_id) and kwargs.get("base_controller") is not None:
        raise ValueError(f"{env_id} is a direct id and takes no base_controller (got "
                         f"{kwargs['base_controller']!r}): use its residual id "
                         f"({env_id.replace('-v', 'Residual-v', 1)} where registered) to "
                         "fly a residual on a base")
    from stable_baselines3.common.vec_env import VecMonitor

    scenario = kwargs.pop("scenario")
    # the episodes' returns and lengths for SB3's log: without it ``learn`` logs no
    # ep_rew_mean (quad-dob train adds its own, over the same class)
    return VecMonitor(QuadrotorSB3VecEnv(n, scenario, **kwargs))
