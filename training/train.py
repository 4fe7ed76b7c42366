"""``quad-dob train``: PPO or SAC (stable-baselines3) on N vehicles of the native vector env.

Read top to bottom: resolve the config (the env id's entry in ``hyperparams/ALGO.yml``, in
rl-zoo3's schema, then the command line), build the vector env, build the model or resume a
checkpoint, train with checkpoints and an evaluation against the base controller, save the
model with its config beside it.

Outputs in ``--out``: ``model.zip`` and ``config.yaml`` (everything needed to rebuild the env
it fits), ``checkpoints/`` (resumable, see ``checkpoints.py``), ``tb/`` (tensorboard),
``evaluations.csv`` (the training curve: the policy's and the base controller's RMS position
error on held-out seeds), ``train.log``.
"""

from __future__ import annotations

import csv
import inspect
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import yaml
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

import quad_dob_env
from quad_dob_env.validation import unknown_name_error
from quad_dob_training.checkpoints import (
    ResumableCheckpoint,
    latest_checkpoint,
    load_state,
    unpickle_env_stack,
)
from quad_dob_training.metrics import flight_metrics
from quad_dob_training.policies import ALGORITHMS, Policy, algorithm_class, fly_policy, load_zip
from quad_dob_training.vec_env import QuadrotorSB3VecEnv

HYPERPARAMS = Path(__file__).parent / "hyperparams"
MODES = ("residual", "direct")
# rl-zoo3's keys that are not the algorithm's own keywords
SCHEMA_KEYS = ("env_kwargs", "n_envs", "n_timesteps", "policy", "normalize", "policy_kwargs")
# keywords of the algorithm that the run itself sets
RUN_KEYWORDS = ("self", "policy", "env", "policy_kwargs", "seed", "device", "verbose",
                "tensorboard_log", "_init_setup_model")
NORMALIZE_KEYS = ("norm_obs", "norm_reward")
EVAL_SEEDS = list(range(10_000, 10_008))  # held out: training seeds count up from --seed
OBSERVATION_CLIP = 10.0


def algorithm_keywords(algo: str) -> tuple[str, ...]:
    """The keywords of SB3's constructor that a hyperparameter file may set."""
    parameters = inspect.signature(algorithm_class(algo).__init__).parameters
    return tuple(name for name in parameters if name not in RUN_KEYWORDS)


def _schedule(value: Any) -> Any:
    """rl-zoo3's ``lin_X``: X decayed linearly to 0 over training; numbers stay numbers."""
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        return lambda progress_remaining: progress_remaining * start
    return value


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
    if env_id not in quad_dob_env.ENV_IDS:
        raise unknown_name_error("env id", env_id, quad_dob_env.ENV_IDS)
    residual_id = "Residual" in env_id
    if (mode == "residual") != residual_id:
        raise ValueError(f"mode {mode!r} does not fit env {env_id!r}: residual training takes "
                         "a ...Residual-v1 id, direct training the others")
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
        "versions": {"quad_dob_env": quad_dob_env.__version__, "torch": str(torch.__version__),
                     "stable_baselines3": __import__("stable_baselines3").__version__},
    }


def normalization(venv: Any) -> dict[str, Any] | None:
    """The running observation statistics as plain numbers, so a model's config carries
    them (``Policy.act`` applies them) and no pickle is needed; None when not normalised."""
    if not isinstance(venv, VecNormalize) or not venv.norm_obs:
        return None
    return {"mean": venv.obs_rms.mean.tolist(), "var": venv.obs_rms.var.tolist(),
            "count": float(venv.obs_rms.count), "epsilon": float(venv.epsilon),
            "clip": float(venv.clip_obs)}


class BaselineEvaluation(BaseCallback):
    """Every ``every`` timesteps: fly the policy on held-out seeds, beside the base
    controller (flown once), and log both RMS position errors (t >= 2 s) and crash rates.
    The best policy so far (fewest crashes, then lowest error) is saved as ``best_model.zip``
    with its ``best_model.yaml``."""

    def __init__(self, config: dict, out: Path, every: int) -> None:
        super().__init__()
        self.config, self.out, self.every = config, out, every
        self._next: int | None = None
        self._best: tuple[float, float] | None = None
        self.first_better: str | None = None  # when the policy first beat the base
        self._started = 0.0
        self._scenario = quad_dob_env.make_scenario(config["env_kwargs"]["scenario"])
        self.base_scores = None
        if config["base_controller"]:
            self.base_scores = self._score(Policy(config["base_controller"],
                                                  config["base_controller"]))

    def checkpoint_state(self) -> dict[str, Any]:
        return {"next": self._next, "best": self._best, "first_better": self.first_better}

    def restore(self, state: dict[str, Any]) -> None:
        self._next, self._best = state["next"], state["best"]
        self.first_better = state.get("first_better")

    def _score(self, policy: Policy) -> tuple[float, float]:
        metrics = [flight_metrics(f) for f in fly_policy(policy, self._scenario, EVAL_SEEDS)]
        return (float(np.mean([m["rms_position_settled"] for m in metrics])),
                float(np.mean([m["crashed"] for m in metrics])))

    def _on_training_start(self) -> None:
        self._started = time.perf_counter()
        if self._next is None:
            self._next = self.num_timesteps + self.every
        self._evaluate()

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            self._next += self.every
            self._evaluate()
        return True

    def _on_training_end(self) -> None:
        self._evaluate()

    def _evaluate(self) -> None:
        config = {**self.config,
                  "observation_normalization": normalization(self.model.get_env())}
        policy = Policy("policy", self.config["base_controller"], self.model, config)
        rms, crashes = self._score(policy)
        self.logger.record("eval/rms_position", rms)
        self.logger.record("eval/crash_rate", crashes)
        row = {"timesteps": self.num_timesteps, "rms_position": rms, "crash_rate": crashes}
        if self.base_scores is not None:
            self.logger.record("eval/base_rms_position", self.base_scores[0])
            row.update(base_rms_position=self.base_scores[0], base_crash_rate=self.base_scores[1])
            base_rms, base_crashes = self.base_scores
            if (self.first_better is None and self.num_timesteps > 0
                    and (crashes, rms) < (base_crashes, base_rms)):
                self.first_better = (f"first better than the base at {self.num_timesteps:,} "
                                     f"timesteps, {time.perf_counter() - self._started:.1f} s "
                                     f"after training (re)started ({rms:.4f} m against "
                                     f"{base_rms:.4f} m)")
                print(self.first_better, flush=True)
        if self._best is None or (crashes, rms) < self._best:
            self._best = (crashes, rms)
            self.model.save(self.out / "best_model.zip")
            (self.out / "best_model.yaml").write_text(
                yaml.safe_dump({**config, "best_at_timesteps": self.num_timesteps,
                                "best_eval_rms_position": rms}, sort_keys=False))
        path = self.out / "evaluations.csv"
        new = not path.exists()
        with open(path, "a", newline="") as file:
            writer = csv.DictWriter(file, fieldnames=list(row))
            if new:
                writer.writeheader()
            writer.writerow(row)


def make_vec_env(config: dict[str, Any]) -> Any:
    """The config's vehicles as an SB3 VecEnv (episode statistics included), behind
    ``VecNormalize`` when the config normalises."""
    torch.set_num_threads(1)  # small MLPs: threads cost more than they save, and the env
    # already uses every core for large batches
    venv = VecMonitor(QuadrotorSB3VecEnv(config["n_envs"], seed=config["seed"],
                                         **config["env_kwargs"]))
    if config["normalize"]:
        venv = VecNormalize(venv, gamma=config["algo_kwargs"].get("gamma", 0.99),
                            clip_obs=OBSERVATION_CLIP, **config["normalize"])
        saved = config.get("observation_normalization")
        if saved:  # going on from a model: its statistics, not fresh ones
            venv.obs_rms.mean = np.array(saved["mean"])
            venv.obs_rms.var = np.array(saved["var"])
            venv.obs_rms.count = saved["count"]
    return venv


def make_model(config: dict[str, Any], venv: Any, tensorboard: Path) -> Any:
    """A fresh model of the config's algorithm, policy and hyperparameters."""
    return algorithm_class(config["algo"])(
        config["policy"], venv, seed=config["seed"], device="cpu", verbose=0,
        tensorboard_log=str(tensorboard), policy_kwargs=config["policy_kwargs"],
        **{key: _schedule(value) for key, value in config["algo_kwargs"].items()})


def train(config: dict[str, Any], out: Path, resume: Path | None = None,
          checkpoint_every: int = 100_000, evaluate_every: int = 100_000,
          progress_bar: bool = True) -> Any:
    """Train (or resume) the run ``config`` describes into ``out``.

    ``resume`` is a checkpoint's ``.state`` (or a run folder: its newest): the run goes on
    with the checkpoint's config, env and RNGs to ``n_timesteps``, ending where the run
    would have ended had it never stopped. A bare model ``.zip`` instead trains
    ``n_timesteps`` more from its weights, on a fresh env."""
    out.mkdir(parents=True, exist_ok=True)
    algorithm = algorithm_class(config["algo"])
    state = None
    if resume is not None and Path(resume).suffix != ".zip":
        state_path = Path(resume) if Path(resume).is_file() else latest_checkpoint(resume)
        state = load_state(state_path)
        config = {**state["config"], "n_timesteps": config["n_timesteps"]}
        venv = unpickle_env_stack(state["env"])
        # force_reset=False: the zip's last observation is the one the pickled env is at
        model = load_zip(algorithm, state_path.with_suffix(".zip"), env=venv,
                         force_reset=False, tensorboard_log=str(out / "tb"))
        replay = state_path.with_name(state_path.stem + "_replay.pkl")
        if replay.is_file():
            model.load_replay_buffer(replay)
        remaining = config["n_timesteps"] - model.num_timesteps
        print(f"resuming {state_path} at {model.num_timesteps:,} of "
              f"{config['n_timesteps']:,} timesteps")
    else:
        venv = make_vec_env(config)
        if resume is not None:
            model = load_zip(algorithm, resume, env=venv, tensorboard_log=str(out / "tb"))
        else:
            model = make_model(config, venv, out / "tb")
        remaining = config["n_timesteps"]
    (out / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    evaluation = BaselineEvaluation(config, out, evaluate_every)
    checkpoint = ResumableCheckpoint(out / "checkpoints", checkpoint_every, config,
                                     [evaluation], restore=state)
    if state is not None:
        evaluation.restore(state["callbacks"][0])
    start = time.perf_counter()
    steps_before = model.num_timesteps
    model.learn(max(remaining, 0), callback=[checkpoint, evaluation], progress_bar=progress_bar,
                reset_num_timesteps=resume is None, tb_log_name=config["algo"])
    wall = time.perf_counter() - start
    config["observation_normalization"] = normalization(venv)
    (out / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    model.save(out / "model.zip")
    rate = (model.num_timesteps - steps_before) / wall
    message = (f"trained {model.num_timesteps - steps_before:,} timesteps in {wall:.1f} s "
               f"({rate:,.0f} timesteps/s, evaluations included) -> {out / 'model.zip'}")
    print(message)
    with open(out / "train.log", "a") as log:
        log.write(message + "\n")
        if evaluation.first_better:
            log.write(evaluation.first_better + "\n")
    plot_training_curve(out / "evaluations.csv", out / "training_curve.png")
    return model


def plot_training_curve(evaluations: Path, path: Path) -> None:
    """The policy's RMS position error on the held-out seeds against timesteps, beside the
    base controller's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(evaluations) as file:
        rows = list(csv.DictReader(file))
    timesteps = [int(row["timesteps"]) for row in rows]
    figure, axis = plt.subplots(figsize=(5.5, 3.4))
    axis.plot(timesteps, [float(row["rms_position"]) for row in rows], "o-", label="policy")
    if "base_rms_position" in rows[0]:
        axis.axhline(float(rows[0]["base_rms_position"]), color="k", linestyle="--",
                     label="base controller alone")
    errors = [float(row["rms_position"]) for row in rows]
    if max(errors) > 20 * min(errors) > 0:  # from a crash to millimetres: on a log scale
        axis.set_yscale("log")
    axis.set_xlabel("timesteps")
    axis.set_ylabel("RMS position error, t ≥ 2 s [m]")
    axis.set_title(f"held-out seeds {EVAL_SEEDS[0]}-{EVAL_SEEDS[-1]}", fontsize=9)
    axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def main(algo: str, mode: str, env_id: str, scenario: str | None, timesteps: int | None,
         n_envs: int | None, seed: int, out: Path | None, resume: Path | None,
         base_controller: str | None, checkpoint_every: int, evaluate_every: int,
         progress_bar: bool, hyperparams: Path | None = None) -> int:
    """``quad-dob train``. Resuming a checkpoint takes its run's config (the env, the
    algorithm and its hyperparameters) and ignores those options; ``--timesteps`` may
    lengthen the run."""
    if resume is not None and not Path(resume).exists():
        raise ValueError(f"--resume {str(resume)!r} does not exist: give a run folder, a "
                         "checkpoint's .state or a model .zip")
    if resume is not None and Path(resume).suffix != ".zip":
        # a checkpoint carries its run's whole config: nothing is resolved again (the
        # hyperparameter file may have changed, or be a --conf-file given no longer)
        state_path = Path(resume) if Path(resume).is_file() else latest_checkpoint(resume)
        saved = load_state(state_path)["config"]
        config = {**saved, "n_timesteps": int(timesteps or saved["n_timesteps"])}
        train(config, Path(out or state_path.parent.parent), state_path, checkpoint_every,
              evaluate_every, progress_bar)
        return 0
    config = resolve_config(algo, mode, env_id, scenario, timesteps, n_envs, seed,
                            base_controller, hyperparams)
    if resume is not None:
        # a bare model: the run's observation statistics, from its config.yaml
        for folder in (Path(resume).parent, Path(resume).parent.parent):
            if (folder / "config.yaml").is_file():
                saved = yaml.safe_load((folder / "config.yaml").read_text())
                config["observation_normalization"] = saved.get("observation_normalization")
                break
    train(config, Path(out or f"runs/{algo}"), resume, checkpoint_every, evaluate_every,
          progress_bar)
    return 0
