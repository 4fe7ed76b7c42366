"""The evaluation during training: ``BaselineEvaluation`` flies the policy on held-out seeds
(``EVAL_SEEDS``) beside the base controller, every so many timesteps, into
``evaluations.csv`` and ``best_model.zip``; an evaluation falls due every so many
timesteps and runs at the next rollout's start, so each row scores the weights trained on
exactly its timesteps, and the last row the final model; ``plot_training_curve`` draws that CSV as
``training_curve.png``; ``normalization`` is the observation statistics a model's config
carries.
"""

from __future__ import annotations

import csv
import io
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecNormalize

import quad_dob_env
from quad_dob_env.benchmark import scenario_options_for
from quad_dob_training.evaluation.metrics import flight_metrics
from quad_dob_training.evaluation.ranking import Standing, beats, candidates, strongest
from quad_dob_training.policies import Policy, fly_policy
from quad_dob_training.rl.run_folder import save_model, write_text_atomically

EVAL_SEEDS = list(range(10_000, 10_008))  # held out: training seeds count up from --seed


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
    with its ``best_model.yaml``. From Benchmark v2's loop on, the classical names the
    benchmark compares (``evaluation.ranking.candidates``) are flown once too, and the
    strongest of them (``evaluation.ranking``'s one rule, as every ranking) is logged beside
    the base, with when the policy first beat it.

    The rows live here and the CSV is rewritten from them, so that it holds exactly this
    run's rows: a checkpoint carries the rows up to it, and a resumed run starts from those,
    dropping any the killed process wrote after the checkpoint (the resumed run evaluates
    those timesteps again, to the same numbers)."""

    def __init__(self, config: dict, out: Path, every: int) -> None:
        super().__init__()
        self.config, self.out, self.every = config, out, every
        self._next: int | None = None
        self._best: tuple[float, float] | None = None
        self._last: int | None = None  # timesteps of the latest evaluation
        self.rows: list[dict[str, Any]] = []
        self.first_better: str | None = None  # when the policy first beat the base
        self._started = 0.0
        # in the loop the policy trains in (a -v2 id's benchmark), on the scenario as named:
        # options that widen the training distribution (a start spread) are not the task
        env_kwargs = config["env_kwargs"]
        benchmark = (env_kwargs.get("scenario_options") or {}).get(
            "benchmark", env_kwargs.get("benchmark"))
        self._scenario = quad_dob_env.make_scenario(
            env_kwargs["scenario"], **scenario_options_for(None, benchmark))
        self.base_scores = None
        if config["base_controller"]:
            self.base_scores = self._score(Policy(config["base_controller"],
                                                  config["base_controller"]))
        # in v2's, v3's and v4's loops, also the strongest classical baseline (each flown
        # once, at that benchmark's gains)
        self.strongest: tuple[str, float, float] | None = None
        self.first_beat_strongest: str | None = None
        if benchmark in ("v2", "v3", "v4"):
            scores = {name: self._score(Policy(name, name)) for name in candidates(benchmark)}
            name = strongest({key: Standing(crashes, rms)
                              for key, (rms, crashes) in scores.items()}, scores)
            self.strongest = (name, *scores[name])

    def checkpoint_state(self) -> dict[str, Any]:
        return {"next": self._next, "best": self._best, "first_better": self.first_better,
                "first_beat_strongest": self.first_beat_strongest,
                "last": self._last, "rows": [dict(row) for row in self.rows]}

    def restore(self, state: dict[str, Any], timesteps: int, source: Path) -> None:
        """Go on from a checkpoint at ``timesteps`` of the run in folder ``source``."""
        self._next, self._best = state["next"], state["best"]
        self.first_better = state.get("first_better")
        self.first_beat_strongest = state.get("first_beat_strongest")
        self._last = state.get("last")
        if "rows" in state:
            self.rows = [dict(row) for row in state["rows"]]
        else:  # a checkpoint from before rows travelled with it: its run's CSV, up to it
            self.rows = _rows_up_to(source / "evaluations.csv", timesteps)
        self._write_rows()

    def _score(self, policy: Policy) -> tuple[float, float]:
        metrics = [flight_metrics(f) for f in fly_policy(policy, self._scenario, EVAL_SEEDS)]
        return (float(np.mean([m["rms_position_settled"] for m in metrics])),
                float(np.mean([m["crashed"] for m in metrics])))

    def _on_training_start(self) -> None:
        self._started = time.perf_counter()
        if self._next is None:  # a fresh run; a resumed one restored its counters and rows
            self._next = self.num_timesteps + self.every
            self._evaluate()

    def _on_rollout_start(self) -> None:
        # At a rollout's start the weights are those trained on exactly num_timesteps: an
        # evaluation in the middle of a rollout would score the weights of the rollout's
        # start under a later count, and the one at training end, at the same count, the
        # updated weights: two rows of one count with different numbers.
        if self.num_timesteps >= self._next:
            while self._next <= self.num_timesteps:
                self._next += self.every
            self._evaluate()

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if self._last != self.num_timesteps:  # not twice at the same timesteps
            self._evaluate()

    def _evaluate(self) -> None:
        config = {**self.config,
                  "observation_normalization": normalization(self.model.get_env())}
        policy = Policy("policy", self.config["base_controller"], self.model, config)
        rms, crashes = self._score(policy)
        self._last = self.num_timesteps
        self.logger.record("eval/rms_position", rms)
        self.logger.record("eval/crash_rate", crashes)
        row = {"timesteps": self.num_timesteps, "rms_position": rms, "crash_rate": crashes}
        if self.base_scores is not None:
            self.logger.record("eval/base_rms_position", self.base_scores[0])
            row.update(base_rms_position=self.base_scores[0], base_crash_rate=self.base_scores[1])
            base_rms, base_crashes = self.base_scores
            if (self.first_better is None and self.num_timesteps > 0
                    and beats(Standing(crashes, rms), Standing(base_crashes, base_rms))):
                self.first_better = (f"first better than the base at {self.num_timesteps:,} "
                                     f"timesteps, {time.perf_counter() - self._started:.1f} s "
                                     f"after training (re)started ({rms:.4f} m against "
                                     f"{base_rms:.4f} m)")
                print(self.first_better, flush=True)
        if self.strongest is not None:
            name, strongest_rms, strongest_crashes = self.strongest
            row.update(strongest_baseline=name, strongest_rms_position=strongest_rms)
            if (self.first_beat_strongest is None and self.num_timesteps > 0
                    and beats(Standing(crashes, rms),
                              Standing(strongest_crashes, strongest_rms))):
                self.first_beat_strongest = (
                    f"first better than the strongest classical baseline ({name}) at "
                    f"{self.num_timesteps:,} timesteps, "
                    f"{time.perf_counter() - self._started:.1f} s after training (re)started "
                    f"({rms:.4f} m against {strongest_rms:.4f} m)")
                print(self.first_beat_strongest, flush=True)
        if self._best is None or beats(Standing(crashes, rms), Standing(*self._best)):
            self._best = (crashes, rms)
            save_model(self.model, self.out / "best_model.zip", self.config.get("run_id"),
                       self.config.get("env_id"))
            write_text_atomically(self.out / "best_model.yaml", yaml.safe_dump(
                {**config, "best_at_timesteps": self.num_timesteps,
                 "best_eval_rms_position": rms}, sort_keys=False))
        self.rows.append(row)
        self._write_rows()
        if not sys.stdout.isatty():  # a log, where the progress bar shows nothing till the end
            print(f"{self.num_timesteps:,} timesteps: RMS position {rms:.4f} m, crash rate "
                  f"{crashes:.2f}" + ("" if self.base_scores is None else
                                      f" (base {self.base_scores[0]:.4f} m)")
                  + f", {time.perf_counter() - self._started:.0f} s", flush=True)

    def _write_rows(self) -> None:
        if not self.rows:
            return
        text = io.StringIO(newline="")
        writer = csv.DictWriter(text, fieldnames=list(self.rows[0]))
        writer.writeheader()
        writer.writerows(self.rows)
        write_text_atomically(self.out / "evaluations.csv", text.getvalue())


def _rows_up_to(path: Path, timesteps: int) -> list[dict[str, Any]]:
    """An old run's CSV rows up to ``timesteps``, one per evaluation: a resume before this
    fix could append a second row of the timesteps it resumed at, and the last one counts."""
    if not path.is_file():
        return []
    with open(path, newline="") as file:
        rows = {int(row["timesteps"]): row for row in csv.DictReader(file)
                if int(row["timesteps"]) <= timesteps}
    return [rows[key] for key in sorted(rows)]



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
