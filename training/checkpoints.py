"""Checkpoints a killed training resumes from, to the same policy as a run never stopped.

A checkpoint is taken between two rollouts (after an update, before the next rollout's first
action), the only moment at which an SB3 algorithm holds no half-collected data. It is two
files in ``checkpoints/``:

| file                      | holds                                                         |
|---------------------------|---------------------------------------------------------------|
| ``{algo}_{steps}.zip``    | SB3's own save: weights, optimiser, timestep count, last obs  |
| ``{algo}_{steps}.state``  | what SB3 does not save: every vehicle's state and generator   |
|                           | (the pickled env stack), observation statistics, the global   |
|                           | RNGs (torch, numpy, random, action space), the callbacks'     |
|                           | counters, the run's config; the replay buffer, off-policy     |
|                           | (``{algo}_{steps}_replay.pkl``)                               |

Both are written to a temporary name and renamed, the state last, so a kill while writing
leaves the previous checkpoint whole and the new one absent. The state files are pickles:
resume only runs you made.
"""

from __future__ import annotations

import inspect
import io
import os
import pickle
import random
import re
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnvWrapper

_NAME = re.compile(r"^(?P<algo>[a-z0-9]+)_(?P<steps>\d+)\.state$")


def _write_atomically(path: Path, data: bytes) -> None:
    partial = path.with_name(path.name + ".partial")
    with open(partial, "wb") as file:
        file.write(data)
        file.flush()
        os.fsync(file.fileno())
    os.replace(partial, path)


def pickle_env_stack(venv: Any) -> bytes:
    """The env stack (SB3 wrappers over the native vector env) as bytes. A wrapper keeps a
    table of its class's members that cannot be pickled (and ``VecNormalize`` pickles without
    its inner env), so each wrapper's own fields are saved and the stack rebuilt."""
    layers = []
    while isinstance(venv, VecEnvWrapper):
        fields = {k: v for k, v in vars(venv).items() if k not in ("venv", "class_attributes")}
        layers.append((type(venv), fields))
        venv = venv.venv
    return pickle.dumps({"base": venv, "layers": layers})


def unpickle_env_stack(data: bytes) -> Any:
    saved = pickle.loads(data)
    venv = saved["base"]
    for wrapper_class, fields in reversed(saved["layers"]):
        wrapper = wrapper_class.__new__(wrapper_class)
        wrapper.__dict__.update(fields)
        wrapper.venv = venv
        wrapper.class_attributes = dict(inspect.getmembers(wrapper_class))
        venv = wrapper
    return venv


def rng_states(model: Any) -> dict[str, Any]:
    # SB3 shuffles minibatches with numpy's legacy global generator, so its state is saved
    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(),  # noqa: NPY002
            "random": random.getstate(),
            "action_space": model.action_space.np_random.bit_generator.state}


def set_rng_states(model: Any, states: dict[str, Any]) -> None:
    torch.set_rng_state(states["torch"])
    np.random.set_state(states["numpy"])  # noqa: NPY002
    random.setstate(states["random"])
    model.action_space.np_random.bit_generator.state = states["action_space"]


class ResumableCheckpoint(BaseCallback):
    """Every ``every`` timesteps, at the first rollout start past it, write a checkpoint;
    ``callbacks`` are the others whose ``checkpoint_state()`` travels with it. Given
    ``restore`` (a loaded state), the global RNGs are set from it at the first rollout
    start, after anything that ran at training start."""

    def __init__(self, folder: Path, every: int, config: dict[str, Any],
                 callbacks: list[Any], restore: dict[str, Any] | None = None) -> None:
        super().__init__()
        self.folder, self.every, self.config = Path(folder), every, config
        self.callbacks, self._restore = callbacks, restore
        self._next = every if restore is None else restore["checkpoint_next"]

    def _on_rollout_start(self) -> None:
        if self._restore is not None:
            set_rng_states(self.model, self._restore["rng"])
            self._restore = None
        elif self.num_timesteps >= self._next:
            self.save()

    def _on_step(self) -> bool:
        return True

    def save(self) -> Path:
        while self._next <= self.num_timesteps:
            self._next += self.every
        self.folder.mkdir(parents=True, exist_ok=True)
        stem = f"{self.config['algo']}_{self.num_timesteps}"
        archive = io.BytesIO()
        self.model.save(archive)
        _write_atomically(self.folder / f"{stem}.zip", archive.getvalue())
        if isinstance(self.model, OffPolicyAlgorithm):
            _write_atomically(self.folder / f"{stem}_replay.pkl",
                              pickle.dumps(self.model.replay_buffer))
        state = {"config": self.config, "num_timesteps": self.num_timesteps,
                 "env": pickle_env_stack(self.model.get_env()), "rng": rng_states(self.model),
                 "checkpoint_next": self._next,
                 "callbacks": [c.checkpoint_state() for c in self.callbacks]}
        path = self.folder / f"{stem}.state"
        _write_atomically(path, pickle.dumps(state))
        return path


def latest_checkpoint(folder: Path) -> Path:
    """The newest complete checkpoint (its ``.state``) of a run folder or checkpoints
    folder."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"checkpoint {str(folder)!r} does not exist: give a run folder, its "
                         "checkpoints/ folder or an ALGO_STEPS.state in it")
    if (folder / "checkpoints").is_dir():
        folder = folder / "checkpoints"
    found = sorted((int(m["steps"]), folder / m.string) for p in folder.glob("*.state")
                   if (m := _NAME.match(p.name)))
    if not found:
        raise ValueError(f"no checkpoint in {str(folder)!r} (looked for ALGO_STEPS.state "
                         "beside ALGO_STEPS.zip); train without --resume")
    return found[-1][1]


def load_state(path: Path) -> dict[str, Any]:
    """A checkpoint's state, or a ValueError naming the file when it is cut off or
    damaged."""
    path = Path(path)
    try:
        state = pickle.loads(path.read_bytes())
    except Exception as error:  # pickle raises many kinds on damaged input
        raise ValueError(f"checkpoint state {str(path)!r} could not be read "
                         f"({type(error).__name__}): it is damaged; resume from an earlier "
                         "checkpoint in the same folder, or train again") from error
    if not isinstance(state, dict) or "config" not in state or "env" not in state:
        raise ValueError(f"checkpoint state {str(path)!r} is not a quad-dob train checkpoint")
    if not path.with_suffix(".zip").is_file():
        raise ValueError(f"checkpoint {str(path)!r} has no model beside it "
                         f"({path.with_suffix('.zip').name})")
    return state
