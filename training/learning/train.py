"""``quad-dob train``: PPO or SAC (stable-baselines3) on N vehicles of the native vector env.

Read top to bottom: set up the process (``setup_process``: the same torch settings for a
fresh run and a resumed one), build the vector env and the model, lock the run folder, start
fresh or resume a checkpoint, train with checkpoints and an evaluation against the base
controller, save the model with its config beside it; ``main`` last, which first resolves the
config (``rl.run_config``: the env id's entry in ``hyperparams/ALGO.yml``, in rl-zoo3's
schema, then the command line). The run folder's id and lock live in ``rl.run_folder``,
checkpoints in ``rl.checkpoints``, the evaluation and training curve in
``baseline_evaluation``.

Outputs in ``--out``:

| file                 | holds                                                             |
|----------------------|-------------------------------------------------------------------|
| ``config.yaml``      | everything needed to rebuild the env the model fits, and the run: |
|                      | its id, its checkpoint and evaluation intervals, the versions and |
|                      | CPU it was trained with                                           |
| ``model.zip``        | the final model (SB3's zip, plus the run id as a member)          |
| ``best_model.zip``   | the best evaluated model so far, ``best_model.yaml`` its config   |
| ``checkpoints/``     | resumable checkpoints, see ``rl/checkpoints.py``                  |
| ``evaluations.csv``  | the training curve: the policy's and the base controller's RMS    |
|                      | position error and crash rate on held-out seeds, one row per      |
|                      | evaluation; a resumed run's rows are those of a run never stopped |
| ``run.lock``         | held (``flock``) while a run trains here: the holder's pid, host  |
|                      | and start time; empty once it ended cleanly                       |
| ``tb/``, ``train.log``, ``training_curve.png`` | tensorboard, speed, the curve plotted   |

A run has an id (``config.yaml``'s ``run_id``), written into every file it makes that is
loaded again, so that files of two runs are never taken for one. ``--resume`` goes on with the
run's own config and intervals unless told otherwise, and warns when the versions or the CPU
differ from the run's (then it is no longer bit for bit the run never stopped).
"""

from __future__ import annotations

import inspect
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

from quad_dob_env.memory import check_memory
from quad_dob_training.learning.baseline_evaluation import (
    BaselineEvaluation,
    normalization,
    plot_training_curve,
)
from quad_dob_training.progress import Progress
from quad_dob_training.rl.checkpoints import (
    ResumableCheckpoint,
    latest_checkpoint,
    load_replay_buffer,
    load_state,
    unpickle_env_stack,
)
from quad_dob_training.rl.model_files import algorithm_class, load_weights, load_zip
from quad_dob_training.rl.run_config import (
    environment_versions,
    resolve_config,
    warn_if_environment_changed,
)
from quad_dob_training.rl.run_folder import (
    RunLock,
    folder_config,
    new_run_id,
    run_folder,
    save_model,
    write_text_atomically,
)
from quad_dob_training.rl.vec_env import QuadrotorSB3VecEnv

OBSERVATION_CLIP = 10.0
DEFAULT_INTERVAL = 100_000  # timesteps between checkpoints, and between evaluations


def setup_process() -> None:
    """What the process must be for training to be reproducible bit for bit, the same for a
    fresh run and a resumed one (a resume that skipped it would compute on other settings).
    Called by ``train`` before any torch work.

    One torch thread is the setting that matters: a reduction torch splits over threads (over
    32,768 elements, such as PPO's advantage mean over a large batch) sums in another order on
    two threads than on one, so a run's weights depend on the thread count; the MLPs here
    gain nothing from threads, and the env already uses the cores for large batches. At one
    thread every CPU op these MLPs use (matmuls, elementwise ops, reductions, Adam) computes
    in one fixed order, which the resume test shows bit for bit on a SIGKILLed run.
    ``torch.use_deterministic_algorithms`` is not switched on: it guards ops that are
    nondeterministic on GPUs (atomics, scatter), none of which PPO or SAC use on the CPU, and
    it costs seconds per process (it imports ``torch._inductor``), in every ``quad-dob
    train`` and every test subprocess. (Inter-op threads are not set: torch allows that once
    per process, before any parallel work, and SB3 runs no inter-op work.)"""
    torch.set_num_threads(1)


def _schedule(value: Any) -> Any:
    """rl-zoo3's ``lin_X``: X decayed linearly to 0 over training; numbers stay numbers."""
    if isinstance(value, str) and value.startswith("lin_"):
        start = float(value[4:])
        return lambda progress_remaining: progress_remaining * start
    return value


def make_vec_env(config: dict[str, Any]) -> Any:
    """The config's vehicles as an SB3 VecEnv (episode statistics included), behind
    ``VecNormalize`` when the config normalises."""
    inner = QuadrotorSB3VecEnv(config["n_envs"], seed=config["seed"], **config["env_kwargs"])
    if len(inner.loops) > 1:
        print("loop groups: " + "; ".join(
            f"{group.stop - group.start} vehicles {loop}"
            for group, loop in zip(inner.groups, inner.loops, strict=True)), flush=True)
    venv = VecMonitor(inner)
    if config["normalize"]:
        venv = VecNormalize(venv, gamma=config["algo_kwargs"].get("gamma", 0.99),
                            clip_obs=OBSERVATION_CLIP, **config["normalize"])
        saved = config.get("observation_normalization")
        if saved:  # going on from a model: its statistics, not fresh ones
            venv.obs_rms.mean = np.array(saved["mean"])
            venv.obs_rms.var = np.array(saved["var"])
            venv.obs_rms.count = saved["count"]
    return venv


def check_buffer_memory(config: dict[str, Any], venv: Any) -> None:
    """Refuse, before SB3 allocates it, a rollout buffer (PPO: n_envs x n_steps) or replay
    buffer (SAC: buffer_size) past the memory budget. SB3 keeps them as float32: PPO the
    observation, action, reward, return, episode start, value, log-probability and
    advantage of every step (counted twice: its minibatches are copies), SAC the observation
    and the next, action, reward, done and time-out of every transition."""
    algorithm = algorithm_class(config["algo"])
    defaults = inspect.signature(algorithm.__init__).parameters
    kwargs = config["algo_kwargs"]
    observation = int(np.prod(venv.observation_space.shape))
    action = int(np.prod(venv.action_space.shape))
    if config["algo"] == "ppo":
        steps = int(kwargs.get("n_steps", defaults["n_steps"].default))
        check_memory(2 * config["n_envs"] * steps * (observation + action + 6) * 4,
                     f"PPO's rollout buffer of {config['n_envs']:,} vehicles x n_steps "
                     f"{steps:,}", "train on fewer vehicles (n_envs) or a shorter n_steps")
    else:
        size = int(kwargs.get("buffer_size", defaults["buffer_size"].default))
        check_memory(size * (2 * observation + action + 3) * 4,
                     f"SAC's replay buffer of {size:,} transitions", "a smaller buffer_size")


def make_model(config: dict[str, Any], venv: Any, tensorboard: Path) -> Any:
    """A fresh model of the config's algorithm, policy and hyperparameters."""
    check_buffer_memory(config, venv)
    return algorithm_class(config["algo"])(
        config["policy"], venv, seed=config["seed"], device="cpu", verbose=0,
        tensorboard_log=str(tensorboard), policy_kwargs=config["policy_kwargs"],
        **{key: _schedule(value) for key, value in config["algo_kwargs"].items()})


@dataclass
class RunStart:
    """What ``model.learn`` starts from: the config the run goes on with, its model (with its
    env), the number of timesteps still to train, whether SB3 counts them from 0 (a fresh
    run) or on from the model's count, and, going on from a checkpoint, the checkpoint's
    state and its run folder."""

    config: dict[str, Any]
    model: Any
    remaining: int
    count_from_zero: bool
    state: dict[str, Any] | None = None
    source: Path | None = None


def _interval(given: int | None, recorded: int | None) -> int:
    return int(given if given is not None else recorded if recorded is not None
               else DEFAULT_INTERVAL)


def _record_new_run(config: dict[str, Any], checkpoint_every: int | None,
                    evaluate_every: int | None) -> None:
    """A new run's own id (even where the config came from another run's config.yaml), its
    intervals and this process's versions, into ``config``."""
    config["run_id"] = new_run_id()
    config["checkpoint_every"] = _interval(checkpoint_every, None)
    config["evaluate_every"] = _interval(evaluate_every, None)
    config["versions"] = environment_versions()


def _start_fresh(config: dict[str, Any], out: Path, checkpoint_every: int | None,
                 evaluate_every: int | None) -> RunStart:
    _record_new_run(config, checkpoint_every, evaluate_every)
    model = make_model(config, make_vec_env(config), out / "tb")
    return RunStart(config, model, config["n_timesteps"], count_from_zero=True)


def _start_from_model(config: dict[str, Any], path: Path, out: Path,
                      checkpoint_every: int | None, evaluate_every: int | None) -> RunStart:
    """A new run of ``config`` from a bare model's weights: the model is built from the
    config and the zip's tensors loaded into it (``model_files.load_weights``), so nothing
    in the zip is unpickled, whoever made it."""
    saved = folder_config(run_folder(path))
    if saved is not None:  # the network the weights fit, and the observation statistics
        # they were trained on, which the zip does not hold
        for key in ("policy", "policy_kwargs", "observation_normalization"):
            if key in saved:
                config[key] = saved[key]
    _record_new_run(config, checkpoint_every, evaluate_every)
    model = make_model(config, make_vec_env(config), out / "tb")
    load_weights(model, path)
    return RunStart(config, model, config["n_timesteps"], count_from_zero=False)


def _start_from_checkpoint(config: dict[str, Any] | None, resume: Path, out: Path,
                           checkpoint_every: int | None, evaluate_every: int | None,
                           trust_pickle: bool) -> RunStart:
    """The run a checkpoint is of, at the checkpoint: its own config and intervals (those
    given replace them), its env, RNGs and callbacks' state."""
    state_path = resume if resume.is_file() else latest_checkpoint(resume)
    state = load_state(state_path, trust_pickle)
    saved = state["config"]
    timesteps = (config or {}).get("n_timesteps") or saved["n_timesteps"]
    # an old run (no run id) stays one: its earlier checkpoints would be another run's
    config = {**saved, "n_timesteps": int(timesteps),
              "checkpoint_every": _interval(checkpoint_every, saved.get("checkpoint_every")),
              "evaluate_every": _interval(evaluate_every, saved.get("evaluate_every"))}
    if out.resolve() != run_folder(state_path).resolve():
        # going on elsewhere is a copy of the run, which may go on in its own folder too:
        # its own id, so that the two are never taken for one
        config["run_id"] = new_run_id()
    warn_if_environment_changed(saved.get("versions") or {}, state_path)
    venv = unpickle_env_stack(state["env"])
    # force_reset=False: the zip's last observation is the one the pickled env is at
    model = load_zip(algorithm_class(config["algo"]), state_path.with_suffix(".zip"), env=venv,
                     force_reset=False, tensorboard_log=str(out / "tb"))
    replay = state_path.with_name(state_path.stem + "_replay.pkl")
    if replay.is_file():
        load_replay_buffer(model, replay, saved.get("run_id"))
    print(f"resuming {state_path} at {model.num_timesteps:,} of "
          f"{config['n_timesteps']:,} timesteps", flush=True)
    return RunStart(config, model, config["n_timesteps"] - model.num_timesteps,
                    count_from_zero=False, state=state, source=run_folder(state_path))


def train(config: dict[str, Any] | None, out: Path, resume: Path | None = None,
          checkpoint_every: int | None = None, evaluate_every: int | None = None,
          progress_bar: bool = True, trust_pickle: bool = False) -> Any:
    """Train (or resume) the run ``config`` describes into ``out``; the model.

    ``resume`` is a checkpoint's ``.state`` (or a run folder: its newest): the run goes on
    with the checkpoint's config, env and RNGs to ``n_timesteps`` (``config``'s, where given,
    else the run's), ending where the run would have ended had it never stopped; ``config``
    is not needed. A bare model ``.zip`` instead trains ``n_timesteps`` more from its weights,
    on a fresh env, as a new run. ``checkpoint_every`` and ``evaluate_every`` None: the run's
    own (resumed), 100,000 (fresh). A fresh run writes its run id, intervals and versions into
    ``config``, and its observation statistics after training. ``trust_pickle`` allows loading
    a zip or state that nothing shows is a run made here."""
    setup_process()  # before any torch work, on every path
    out = Path(out)
    resume = None if resume is None else Path(resume)
    if resume is not None and not resume.exists():
        raise ValueError(f"--resume {str(resume)!r} does not exist: give a run folder, a "
                         "checkpoint's .state or a model .zip")
    if config is None and (resume is None or resume.suffix == ".zip"):
        raise ValueError("train needs a config unless it resumes a checkpoint")
    with RunLock(out):  # before anything is written into out
        if resume is None:
            start = _start_fresh(config, out, checkpoint_every, evaluate_every)
        elif resume.suffix == ".zip":
            start = _start_from_model(config, resume, out, checkpoint_every, evaluate_every)
        else:
            start = _start_from_checkpoint(config, resume, out, checkpoint_every,
                                           evaluate_every, trust_pickle)
        return _learn(start, out, progress_bar)


# timesteps between two lines of an off-policy run's log (an on-policy run's line is
# one rollout, n_steps x n_envs timesteps)
OFF_POLICY_LINE_EVERY = 10_000


class TrainingProgress(BaseCallback):
    """Off a terminal (where SB3's bar draws nothing until the end), a line per rollout of
    an on-policy algorithm (``OFF_POLICY_LINE_EVERY`` timesteps of another), with the mean
    episode reward so far, and ``progress.Progress``'s heartbeat while an evaluation runs
    long. (A first run's compilation the simulator announces itself.) ``close()`` ends it
    whether or not the training ended normally."""

    def __init__(self, remaining: int, lines: bool) -> None:
        super().__init__()
        self.remaining, self.lines = remaining, lines
        self.report: Progress | None = None
        self._next = 0
        self._every = 1

    def _on_training_start(self) -> None:
        rollout = getattr(self.model, "n_steps", None)
        self._every = (rollout * self.model.n_envs if rollout is not None
                       else OFF_POLICY_LINE_EVERY)
        self._next = self.num_timesteps + self._every
        self.report = Progress("train", -(-max(self.remaining, 0) // self._every),
                               quiet=not self.lines, bar=False)

    def _on_step(self) -> bool:
        if self.report is not None and self.num_timesteps >= self._next:
            self._next += self._every
            rewards = [episode["r"] for episode in self.model.ep_info_buffer or ()]
            self.report.done(f"{self.num_timesteps:,} timesteps" + (
                f", ep_rew_mean {np.mean(rewards):.1f}" if rewards else ""))
        return True

    def close(self) -> None:
        if self.report is not None:
            self.report.close()


def _learn(start: RunStart, out: Path, progress_bar: bool) -> Any:
    config, model = start.config, start.model
    print(f"train: {config['algo']} on {config.get('env_id')}, {max(start.remaining, 0):,} "
          f"timesteps into {out}", file=sys.stderr, flush=True)
    write_text_atomically(out / "config.yaml", yaml.safe_dump(config, sort_keys=False))
    evaluation = BaselineEvaluation(config, out, config["evaluate_every"])
    checkpoint = ResumableCheckpoint(out / "checkpoints", config["checkpoint_every"], config,
                                     [evaluation], restore=start.state)
    if start.state is not None:
        evaluation.restore(start.state["callbacks"][0], start.state["num_timesteps"],
                           start.source)
    began = time.perf_counter()
    steps_before = model.num_timesteps
    # off a terminal the bar draws nothing until the end: the evaluations print lines instead
    bar = progress_bar and sys.stdout.isatty()
    lines = TrainingProgress(start.remaining, lines=not bar)
    try:
        model.learn(max(start.remaining, 0), callback=[checkpoint, evaluation, lines],
                    progress_bar=bar, reset_num_timesteps=start.count_from_zero,
                    tb_log_name=config["algo"])
    finally:  # an error or Ctrl-C mid-run leaves no heartbeat behind
        lines.close()
    wall = time.perf_counter() - began
    config["observation_normalization"] = normalization(model.get_env())
    write_text_atomically(out / "config.yaml", yaml.safe_dump(config, sort_keys=False))
    save_model(model, out / "model.zip", config.get("run_id"), config.get("env_id"))
    rate = (model.num_timesteps - steps_before) / wall
    message = (f"trained {model.num_timesteps - steps_before:,} timesteps in {wall:.1f} s "
               f"({rate:,.0f} timesteps/s, evaluations included) -> {out / 'model.zip'}")
    print(message)
    with open(out / "train.log", "a") as log:
        log.write(message + "\n")
        for line in (evaluation.first_better, evaluation.first_beat_strongest):
            if line:
                log.write(line + "\n")
    plot_training_curve(out / "evaluations.csv", out / "training_curve.png")
    return model


def main(algo: str, mode: str, env_id: str, scenario: str | None, timesteps: int | None,
         n_envs: int | None, seed: int, out: Path | None, resume: Path | None,
         base_controller: str | None, checkpoint_every: int | None = None,
         evaluate_every: int | None = None, progress_bar: bool = True,
         hyperparams: Path | None = None, trust_pickle: bool = False) -> int:
    """``quad-dob train``. Resuming a checkpoint takes its run's config (the env, the
    algorithm and its hyperparameters, the intervals) and ignores those options;
    ``--timesteps`` may lengthen the run, ``--checkpoint-every`` and ``--evaluate-every``
    (None: the run's own) change its intervals from then on."""
    if resume is not None and not Path(resume).exists():
        raise ValueError(f"--resume {str(resume)!r} does not exist: give a run folder, a "
                         "checkpoint's .state or a model .zip")
    if resume is not None and Path(resume).suffix != ".zip":
        # a checkpoint carries its run's whole config: nothing is resolved again (the
        # hyperparameter file may have changed, or be a --conf-file given no longer)
        state_path = Path(resume) if Path(resume).is_file() else latest_checkpoint(resume)
        length = None if timesteps is None else {"n_timesteps": int(timesteps)}
        train(length, Path(out or run_folder(state_path)), state_path, checkpoint_every,
              evaluate_every, progress_bar, trust_pickle)
        return 0
    config = resolve_config(algo, mode, env_id, scenario, timesteps, n_envs, seed,
                            base_controller, hyperparams)
    train(config, Path(out or f"runs/{algo}"), resume, checkpoint_every, evaluate_every,
          progress_bar, trust_pickle)
    return 0
