"""Checkpoints a killed training resumes from, to the same policy as a run never stopped.

A checkpoint is taken between two rollouts (after an update, before the next rollout's first
action), the only moment at which an SB3 algorithm holds no half-collected data. It is two
files in ``checkpoints/`` (three off-policy):

| file                          | holds                                                     |
|-------------------------------|-----------------------------------------------------------|
| ``{algo}_{steps}.zip``        | SB3's own save (weights, optimiser, timestep count, last  |
|                               | obs) plus a member ``quad_dob_run.json``: the run id      |
| ``{algo}_{steps}.state``      | a header line ``quad-dob checkpoint state`` and one JSON  |
|                               | line (format, run id, algo, timesteps), then a pickle of  |
|                               | what SB3 does not save: every vehicle's state and         |
|                               | generator (the pickled env stack), observation            |
|                               | statistics, the global RNGs (torch, numpy, random, action |
|                               | space), the callbacks' counters and evaluation rows, the  |
|                               | run's config                                              |
| ``{algo}_{steps}_replay.pkl`` | off-policy only: the same kind of header, then the pickled|
|                               | replay buffer                                             |

Each is written to a temporary name and renamed, the state last, so a kill while writing
leaves the previous checkpoint whole and the new one absent. Once a new one is whole, the
run's older ones are deleted but the newest ``KEEP_CHECKPOINTS`` (2): a state holds every
vehicle's state and reference table, about 170 MB for 256 vehicles of ``random-tracks``,
and a 3 M-timestep run that kept its 30 checkpoints filled 5 GB.

Every file carries the run's id (see ``run_folder``, with the folder's lock): a state is
unpickled only once its header's run id equals the zip's beside it and the run folder's
``config.yaml``'s (``check_checkpoint``), a replay buffer once its own equals the state's.
"""

from __future__ import annotations

import inspect
import io
import json
import pickle
import random
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnvWrapper

from quad_dob_training.rl.run_folder import (
    HEADER_LIMIT,
    folder_config,
    run_folder,
    save_model,
    write_bytes_atomically,
    zip_run_id,
)

_NAME = re.compile(r"^(?P<algo>[a-z0-9]+)_(?P<steps>\d+)\.state$")
KEEP_CHECKPOINTS = 2  # a run's newest checkpoints kept on disk (``ResumableCheckpoint``)
STATE_MAGIC = b"quad-dob checkpoint state\n"
REPLAY_MAGIC = b"quad-dob replay buffer\n"
HEADER_FORMAT = 1


# --- headers --------------------------------------------------------------------------------

def _with_header(magic: bytes, header: dict[str, Any], payload: bytes) -> bytes:
    return magic + json.dumps(header).encode() + b"\n" + payload


@dataclass(frozen=True)
class HeaderedPickle:
    """A state or replay file split into its JSON header (None: an old file, all pickle)
    and the pickle bytes, which nothing has unpickled yet."""

    header: dict[str, Any] | None
    payload: bytes

    @property
    def run_id(self) -> str | None:
        return None if self.header is None else self.header.get("run_id")


def read_headered(path: Path, magic: bytes, what: str) -> HeaderedPickle:
    """Split a file written by ``_with_header``; a file without ``magic`` is an old one."""
    data = Path(path).read_bytes()
    header, start = _parse_header(data, magic, path, what)
    return HeaderedPickle(header, data[start:])


def _parse_header(data: bytes, magic: bytes, path: Path,
                  what: str) -> tuple[dict[str, Any] | None, int]:
    """The header at the start of ``data`` (None: an old file, all pickle) and where the
    pickle starts."""
    if not data.startswith(magic):
        return None, 0
    end = data.find(b"\n", len(magic), len(magic) + HEADER_LIMIT)
    try:
        if end < 0:
            raise ValueError("no end of header")
        header = json.loads(data[len(magic):end])
        if not isinstance(header, dict):
            raise ValueError("header is not a mapping")
    except ValueError as error:
        raise ValueError(f"{what} {str(path)!r} could not be read (its header: {error}): it "
                         "is damaged; resume from an earlier checkpoint in the same folder, or "
                         "train again") from error
    return header, end + 1


def state_run_id(path: Path) -> str | None:
    """The run id a ``.state`` claims, from its header alone (the file's first bytes: a
    state holds every vehicle's state, some 170 MB, and each checkpoint's pruning asks
    this of the ones before it)."""
    with open(path, "rb") as file:
        head = file.read(len(STATE_MAGIC) + HEADER_LIMIT)
    header, _ = _parse_header(head, STATE_MAGIC, path, "checkpoint state")
    return None if header is None else header.get("run_id")


# --- pickled env stack and RNGs ---------------------------------------------------------------

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


# --- writing checkpoints ----------------------------------------------------------------------

def write_state(path: Path, state: dict[str, Any]) -> None:
    """A checkpoint's ``.state``: the header (its run id, readable without unpickling), then
    the pickled state."""
    config = state["config"]
    header = {"format": HEADER_FORMAT, "run_id": config.get("run_id"),
              "algo": config.get("algo"), "num_timesteps": int(state["num_timesteps"])}
    write_bytes_atomically(Path(path), _with_header(STATE_MAGIC, header, pickle.dumps(state)))


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
        run_id = self.config.get("run_id")
        stem = f"{self.config['algo']}_{self.num_timesteps}"
        save_model(self.model, self.folder / f"{stem}.zip", run_id, self.config.get("env_id"))
        if isinstance(self.model, OffPolicyAlgorithm):
            header = {"format": HEADER_FORMAT, "run_id": run_id}
            write_bytes_atomically(self.folder / f"{stem}_replay.pkl",
                              _with_header(REPLAY_MAGIC, header,
                                           pickle.dumps(self.model.replay_buffer)))
        state = {"config": self.config, "num_timesteps": self.num_timesteps,
                 "env": pickle_env_stack(self.model.get_env()), "rng": rng_states(self.model),
                 "checkpoint_next": self._next,
                 "callbacks": [c.checkpoint_state() for c in self.callbacks]}
        path = self.folder / f"{stem}.state"
        write_state(path, state)  # last: a state on disk means its zip is whole
        self._prune(run_id)
        return path

    def _prune(self, run_id: object) -> None:
        """Delete this run's checkpoints but the newest ``KEEP_CHECKPOINTS`` up to the one
        just written: each holds every vehicle's state, reference tables included (about
        170 MB for 256 vehicles of ``random-tracks``), and a resume reads only the newest
        (the one before it stays in case that one was cut off). Later ones (left by a branch
        given up when an earlier checkpoint was resumed) and another run's files are not
        touched."""
        own = sorted((steps, path) for path in self.folder.glob("*.state")
                     if (m := _NAME.match(path.name)) and m["algo"] == self.config["algo"]
                     and (steps := int(m["steps"])) <= self.num_timesteps
                     and _claimed_run_id(path) == run_id)
        for _, state in own[:-KEEP_CHECKPOINTS]:
            for old in (state, state.with_suffix(".zip"),
                        state.with_name(f"{state.stem}_replay.pkl")):
                old.unlink(missing_ok=True)


# --- finding and loading checkpoints ------------------------------------------------------------

def latest_checkpoint(folder: Path) -> Path:
    """The newest complete checkpoint (its ``.state``) of a run folder or checkpoints
    folder. Where the run folder's ``config.yaml`` names a run id, only that run's
    checkpoints count (another run trained into the folder before may have left its own)."""
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
    config = folder_config(run_folder(found[-1][1])) or {}
    run_id = config.get("run_id")
    if run_id is None:
        return found[-1][1]
    # a damaged header counts as the run's own, so that resuming it names the damage; an
    # old-format state (no header) is not the run's: this run has an id
    own = [path for _, path in found if _claimed_run_id(path) in (run_id, _DAMAGED)]
    if not own:
        raise ValueError(f"no checkpoint in {str(folder)!r} belongs to run {run_id} (the run "
                         f"of {str(run_folder(found[-1][1]) / 'config.yaml')!r}); those there "
                         f"({', '.join(p.name for _, p in found)}) are another run's: move "
                         "them back into their own run folder to resume them, or train "
                         "without --resume")
    return own[-1]


_DAMAGED = object()  # what _claimed_run_id says of a state whose header cannot be read


def _claimed_run_id(path: Path) -> object:
    try:
        return state_run_id(path)
    except ValueError:
        return _DAMAGED


def check_checkpoint(path: Path, trust_pickle: bool = False) -> HeaderedPickle:
    """Everything that can be checked of a checkpoint without unpickling anything; returns
    its state file split, not yet unpickled. Refuses a state and zip of two runs, and a state
    whose run folder's ``config.yaml`` is another run's (or, without ``trust_pickle``,
    absent). An old checkpoint (no run id in either file) in an old run's folder (no run id
    in its config.yaml) passes with a warning."""
    path = Path(path)
    zip_path = path.with_suffix(".zip")
    if not zip_path.is_file():
        raise ValueError(f"checkpoint {str(path)!r} has no model beside it ({zip_path.name})")
    saved = read_headered(path, STATE_MAGIC, "checkpoint state")
    zip_id = zip_run_id(zip_path)
    if saved.run_id != zip_id:
        raise ValueError(f"checkpoint {str(path)!r} is of run {saved.run_id} but "
                         f"{str(zip_path)!r} beside it is of run {zip_id}: the pair mixes two "
                         "runs (two trainings wrote into one folder); resume an earlier "
                         "checkpoint whose files agree, or train again")
    folder = run_folder(path)
    config_path = folder / "config.yaml"
    config = folder_config(folder)
    if config is None:
        if not trust_pickle:
            raise ValueError(f"checkpoint {str(path)!r} has no config.yaml in its run folder "
                             f"{str(folder)!r} to show it is a run made there; loading it "
                             "needs unpickling its .state, which runs code: --trust-pickle "
                             "allows it for a file you made or trust")
    elif config.get("run_id") != saved.run_id:
        raise ValueError(f"checkpoint {str(path)!r} is of run {saved.run_id} but "
                         f"{str(config_path)!r} is of run {config.get('run_id')}: the folder "
                         "holds another run's files; resume a checkpoint of that run, or put "
                         "this checkpoint back in its own run folder")
    if saved.run_id is None:
        warnings.warn(f"checkpoint {str(path)!r} has no run id (written before run ids): "
                      "cannot check that its .state and .zip belong to one run; resuming it "
                      "as it is", stacklevel=2)
    return saved


def load_state(path: Path, trust_pickle: bool = False) -> dict[str, Any]:
    """A checkpoint's state after ``check_checkpoint``, or a ValueError naming the file when
    it is mixed, another run's, cut off or damaged."""
    path = Path(path)
    saved = check_checkpoint(path, trust_pickle)
    try:
        state = pickle.loads(saved.payload)
    except Exception as error:  # pickle raises many kinds on damaged input
        raise ValueError(f"checkpoint state {str(path)!r} could not be read "
                         f"({type(error).__name__}): it is damaged; resume from an earlier "
                         "checkpoint in the same folder, or train again") from error
    if not isinstance(state, dict) or "config" not in state or "env" not in state:
        raise ValueError(f"checkpoint state {str(path)!r} is not a quad-dob train checkpoint")
    return state


def load_replay_buffer(model: Any, path: Path, run_id: str | None) -> None:
    """An off-policy checkpoint's replay buffer into ``model``, after its header's run id is
    checked against the state's."""
    saved = read_headered(path, REPLAY_MAGIC, "replay buffer")
    if saved.run_id != run_id:
        raise ValueError(f"replay buffer {str(path)!r} is of run {saved.run_id}, its "
                         f"checkpoint of run {run_id}: the folder mixes two runs; resume an "
                         "earlier checkpoint whose files agree, or train again")
    model.load_replay_buffer(io.BytesIO(saved.payload))
