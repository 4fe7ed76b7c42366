"""The run as plain data: ``resolve_config`` reads the env id's entry of
``hyperparams/ALGO.yml`` (rl-zoo3's schema, checked key by key against the algorithm's own
keywords; nothing is evaluated) and the command line into one dict, which ``config.yaml``
holds; and the environment a run's numbers depend on beyond it (library versions, CPU),
recorded with the run and compared when it resumes.
"""

from __future__ import annotations

import inspect
import platform
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import yaml

import quad_dob_env
from quad_dob_env.validation import unknown_name_error
from quad_dob_training.rl import ALGORITHMS, HYPERPARAMS
from quad_dob_training.rl.model_files import algorithm_class

MODES = ("residual", "direct")
# rl-zoo3's keys that are not the algorithm's own keywords (``env_wrapper``: only the
# training-only ``loop_randomization.LoopRandomization``, read into ``env_kwargs``)
SCHEMA_KEYS = ("env_kwargs", "n_envs", "n_timesteps", "policy", "normalize", "policy_kwargs",
               "env_wrapper")
# keywords of the algorithm that the run itself sets
RUN_KEYWORDS = ("self", "policy", "env", "policy_kwargs", "seed", "device", "verbose",
                "tensorboard_log", "_init_setup_model")
NORMALIZE_KEYS = ("norm_obs", "norm_reward")


def cpu_name() -> str:
    """The CPU's model name (``/proc/cpuinfo``; elsewhere what ``platform`` says)."""
    try:
        with open("/proc/cpuinfo") as file:
            for line in file:
                if line.startswith("model name"):
                    return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def environment_versions() -> dict[str, str]:
    """What a run's numbers depend on beyond its config: the libraries' versions and the
    CPU (another CPU may round differently in vectorised code)."""
    import numba
    import stable_baselines3

    return {"quad_dob_env": quad_dob_env.__version__, "torch": str(torch.__version__),
            "stable_baselines3": stable_baselines3.__version__, "numpy": np.__version__,
            "numba": numba.__version__, "python": platform.python_version(), "cpu": cpu_name()}


def warn_if_environment_changed(recorded: dict[str, str], where: Path) -> None:
    """A warning naming what differs between the recorded environment and this one. Only
    the keys the run recorded are compared (older runs recorded fewer)."""
    current = environment_versions()
    changed = [f"{key} {recorded[key]} -> {current[key]}" for key in current
               if key in recorded and str(recorded[key]) != current[key]]
    if changed:
        warnings.warn(f"resuming {where} in another environment than the run was trained in "
                      f"({'; '.join(changed)}): training goes on, but no longer bit for bit "
                      "as the run would have gone had it never stopped", stacklevel=3)


def algorithm_keywords(algo: str) -> tuple[str, ...]:
    """The keywords of SB3's constructor that a hyperparameter file may set."""
    parameters = inspect.signature(algorithm_class(algo).__init__).parameters
    return tuple(name for name in parameters if name not in RUN_KEYWORDS)



def _normalize(value: Any, where: str) -> dict[str, bool] | None:
    """rl-zoo3's ``normalize``: false, true (observations and rewards) or a mapping."""
    if value is False or value is None:
        return None
    if value is True:
        return {"norm_obs": True, "norm_reward": True}
    if isinstance(value, dict):
        for key in value:
            if key not in NORMALIZE_KEYS:
                raise unknown_name_error(f"normalize key in {where}", key, NORMALIZE_KEYS)
        return {key: bool(value.get(key, True)) for key in NORMALIZE_KEYS}
    raise ValueError(f"normalize in {where} is {value!r}: write true, false or a YAML "
                     "mapping such as {norm_obs: true, norm_reward: false} (rl-zoo3 also evals "
                     "strings; quad-dob train does not eval config files)")


def resolve_config(algo: str, mode: str, env_id: str, scenario: str | None,
                   timesteps: int | None, n_envs: int | None, seed: int,
                   base_controller: str | None = None,
                   hyperparams: Path | None = None) -> dict[str, Any]:
    """The whole run as plain data: hyperparameters, env options, seed, versions."""
    if algo not in ALGORITHMS:
        raise unknown_name_error("algorithm", algo, ALGORITHMS)
    if mode not in MODES:
        raise unknown_name_error("mode", mode, MODES)
    if env_id not in quad_dob_env.ALL_ENV_IDS:
        raise unknown_name_error("env id", env_id, quad_dob_env.ALL_ENV_IDS)
    residual_id = quad_dob_env.is_residual_id(env_id)
    if (mode == "residual") != residual_id:
        raise ValueError(f"mode {mode!r} does not fit env {env_id!r}: residual training takes "
                         "a ...Residual id, direct training the others")
    hyperparams = Path(hyperparams or HYPERPARAMS / f"{algo}.yml")
    table = yaml.safe_load(hyperparams.read_text())
    if env_id not in table:
        raise ValueError(f"{hyperparams} has no entry for {env_id}; it has: " + ", ".join(table))
    entry = dict(table[env_id])
    where = f"{hyperparams.name} [{env_id}]"
    allowed = (*SCHEMA_KEYS, *algorithm_keywords(algo))
    for key in entry:
        if key not in allowed:
            raise unknown_name_error(f"key in {where}", key, allowed)
    policy_kwargs = entry.get("policy_kwargs", {})
    if not isinstance(policy_kwargs, dict):
        raise ValueError(f"policy_kwargs in {where} must be a YAML mapping, not "
                         f"{policy_kwargs!r} (quad-dob train does not eval config files)")
    env_kwargs = {**gym.spec(env_id).kwargs, **entry.get("env_kwargs", {})}
    if entry.get("env_wrapper") is not None:
        # rl-zoo3's form of the training-only keys, which no env id takes as a keyword
        from quad_dob_training.rl.loop_randomization import training_options

        for key, value in training_options(entry["env_wrapper"], where).items():
            if key in env_kwargs:
                raise ValueError(f"{key} in {where} is given twice, in env_kwargs and as "
                                 "env_wrapper: keep the env_wrapper, which rl-zoo3 takes too")
            env_kwargs[key] = value
    if scenario:
        env_kwargs["scenario"] = scenario
    if base_controller is not None:
        if not residual_id:
            raise ValueError("--base applies to residual training only")
        env_kwargs["base_controller"] = base_controller
    return {
        "algo": algo, "mode": mode, "env_id": env_id, "seed": int(seed),
        "n_envs": int(n_envs or entry.get("n_envs", 64)),
        "n_timesteps": int(timesteps or entry.get("n_timesteps", 1_000_000)),
        "policy": entry.get("policy", "MlpPolicy"),
        "algo_kwargs": {key: value for key, value in entry.items() if key not in SCHEMA_KEYS},
        "policy_kwargs": dict(policy_kwargs),
        "normalize": _normalize(entry.get("normalize", False), where),
        "env_kwargs": env_kwargs,
        "base_controller": env_kwargs.get("base_controller"),
        "versions": environment_versions(),  # train records the training process's own
    }
