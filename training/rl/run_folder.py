"""A run folder's identity and lock: the run id every file a run loads again carries, the
folder's ``config.yaml`` read safely, atomic writes, and ``run.lock``.

**Run ids.** A fresh run draws a run id (``uuid4().hex``) and writes it into ``config.yaml``,
every checkpoint (zip member and state header) and ``model.zip`` / ``best_model.zip`` (the same
zip member). The state and replay files are pickles, which run code when loaded; their header
is read first, as plain JSON, and the pickle is unpickled only when the header's run id
equals both the zip's beside it and the run folder's ``config.yaml`` (``check_checkpoint``);
a pair mixed from two runs, or a state in another run's folder, is refused unread, and a
state whose folder has no ``config.yaml`` needs ``trust_pickle``. Checkpoints written before
run ids existed (no header, no member) still load, with a warning, from a run folder whose
``config.yaml`` has no run id either (an old run's; such a run stays without one when
resumed, so that its earlier checkpoints stay its own).

**One run per folder.** ``RunLock`` holds ``run.lock`` in the run folder with ``flock`` for
the run's whole life, the holder's pid, host and start time written in it. A second run into
the folder is refused at once, naming the holder; the kernel drops the lock of a process that
died, so a killed run's lock is taken over by the next run.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import socket
import sys
import time
import uuid
import warnings
import zipfile
from pathlib import Path
from typing import Any

import yaml

try:
    import fcntl
except ImportError:  # Windows: no flock; RunLock warns that the folder is not locked
    fcntl = None

# the run id and the env id inside a model zip; SB3's load ignores it
RUN_MEMBER = "quad_dob_run.json"
LOCK_NAME = "run.lock"
# a JSON header line (a state's, a lock file's) is a few hundred bytes; reading more than
# this means it is no header
HEADER_LIMIT = 4096


def new_run_id() -> str:
    return uuid.uuid4().hex


def write_bytes_atomically(path: Path, data: bytes) -> None:
    """A file a kill leaves either old or new, never half written (models, checkpoint
    states, replay buffers)."""
    partial = path.with_name(path.name + ".partial")
    with open(partial, "wb") as file:
        file.write(data)
        file.flush()
        os.fsync(file.fileno())
    os.replace(partial, path)


def write_text_atomically(path: Path, text: str) -> None:
    """A file a kill leaves either old or new, never half written (config.yaml, the
    evaluations CSV)."""
    write_bytes_atomically(Path(path), text.encode())


# --- run ids in zips, the folder's config ---------------------------------------------------

def save_model(model: Any, path: Path, run_id: str | None, env_id: str | None = None) -> None:
    """SB3's save of ``model`` with the run id and the env id it was trained on as an extra
    zip member, written atomically: a zip that travels without its config still says which
    id it flies (``zip_env_id``)."""
    archive = io.BytesIO()
    model.save(archive)
    record = {key: value for key, value in (("run_id", run_id), ("env_id", env_id))
              if value is not None}
    if record:
        with zipfile.ZipFile(archive, "a") as bundle:
            bundle.writestr(RUN_MEMBER, json.dumps(record))
    write_bytes_atomically(Path(path), archive.getvalue())


def zip_run_id(path: Path, content: bytes | None = None) -> str | None:
    """The run id a model zip carries (None: written before run ids, or by another tool),
    read from ``content`` where the caller holds the file's bytes already. Reads one JSON
    member; nothing is unpickled."""
    return _zip_record(path, content, "run_id")


def zip_env_id(path: Path, content: bytes | None = None) -> str | None:
    """The env id a model zip records it was trained on (None: saved by SB3 or rl-zoo3, or
    by this project before it recorded one); read as ``zip_run_id`` reads the run id."""
    return _zip_record(path, content, "env_id")


def _zip_record(path: Path, content: bytes | None, key: str) -> str | None:
    path = Path(path)
    if content is None and not path.is_file():
        raise ValueError(f"model file {str(path)!r} does not exist")
    try:
        with zipfile.ZipFile(path if content is None else io.BytesIO(content)) as bundle:
            if RUN_MEMBER not in bundle.namelist():
                return None
            value = json.loads(bundle.read(RUN_MEMBER)).get(key)
            return None if value is None else str(value)
    except (zipfile.BadZipFile, KeyError, ValueError, OSError, AttributeError) as error:
        raise ValueError(f"model file {str(path)!r} is not a stable-baselines3 zip (cut off "
                         f"while written, or not a model; {type(error).__name__}): train again "
                         "or pick another checkpoint") from error


def run_folder(checkpoint: Path) -> Path:
    """The run folder of a checkpoint (``RUN/checkpoints/x.state``) or a model zip
    (``RUN/model.zip``)."""
    checkpoint = Path(checkpoint)
    parent = checkpoint.parent
    return parent.parent if parent.name == "checkpoints" else parent


def folder_config(folder: Path) -> dict[str, Any] | None:
    """A run folder's ``config.yaml`` (YAML, read safely), or None where there is none."""
    path = Path(folder) / "config.yaml"
    if not path.is_file():
        return None
    try:
        config = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ValueError(f"{str(path)!r} is not valid YAML ({error}): restore it or train "
                         "again") from error
    return config if isinstance(config, dict) else None


# --- one run per folder -----------------------------------------------------------------------

class RunLock:
    """``run.lock`` in ``folder``, held with ``flock`` while the ``with`` block runs. The
    kernel releases the lock of a process that ends in any way, so a killed run's lock is
    free again; what it wrote into the file only says who held it last."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self._fd: int | None = None

    def __enter__(self) -> RunLock:
        if self.folder.exists() and not self.folder.is_dir():
            raise ValueError(f"run folder {str(self.folder)!r} is a file: give a folder as "
                             "--out")
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as error:
            raise ValueError(f"run folder {str(self.folder)!r} cannot be written "
                             f"({error.strerror}): give a folder you may write into as --out"
                             ) from error
        if fcntl is None:
            warnings.warn(f"this platform has no flock: {str(self.folder)!r} is not locked "
                          "against a second training into it", stacklevel=2)
            os.close(fd)
            return self
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise ValueError(
                f"run folder {str(self.folder)!r} is in use by another training ({holder}; "
                f"lock file {str(self.path)!r}): wait for it to finish, or train into another "
                "--out") from None
        except OSError as error:
            os.close(fd)
            raise ValueError(f"run folder {str(self.folder)!r} cannot be locked "
                             f"({error.strerror}): train into a folder on a local disk"
                             ) from error
        previous = _holder(fd, missing="")
        if previous:  # a holder that released normally empties the file: this one was killed
            print(f"taking over {self.path} from a run that did not end cleanly ({previous})",
                  flush=True)
        record = {"pid": os.getpid(), "host": socket.gethostname(),
                  "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "command": sys.argv}
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(record) + "\n").encode(), 0)
        # a child forked now would share this open file, and with it the lock: a training
        # forks nothing while it runs (the env runs on threads)
        self._fd = fd
        return self

    def __exit__(self, *_: object) -> None:
        if self._fd is None:
            return
        with contextlib.suppress(OSError):
            os.ftruncate(self._fd, 0)  # empty: the next run knows this one ended cleanly
        os.close(self._fd)  # closing releases the flock
        self._fd = None


def _holder(fd: int, missing: str = "its holder did not say who it is") -> str:
    """Who a lock file says holds it, in words."""
    text = os.pread(fd, HEADER_LIMIT, 0).decode(errors="replace").strip()
    if not text:
        return missing
    try:
        record = json.loads(text)
        return f"pid {record['pid']} on {record['host']}, started {record['started']}"
    except (ValueError, KeyError, TypeError):
        return f"the lock file says {text[:200]!r}"
