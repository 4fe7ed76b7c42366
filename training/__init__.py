"""Training, evaluation, tuning, the paper reproduction and the ``quad-dob`` command line.

The folder ``training/`` installs as ``quad_dob_training``; it sits on top and may import
``quad_dob_env``, ``quad_dob_baselines`` and ``quad_dob_composition``. Inside it, each
folder and top module imports only those below it (the order: docs/design.md, "Layers").

Top modules:

- ``progress``: what long work reports as it goes (a bar on a terminal, a line per unit in
  a log), with the simulator's notice while a first run compiles.
- ``rollout``: ``Flight`` records and ``fly`` (controllers through scenarios, batched: a
  whole flight; "fly" means nothing else in the project).
- ``policies``: policies by name (controllers, ``py:`` ones, ``ALGO:PATH``, ``residual``)
  and flying them over many seeds; models load through ``rl.model_files``.
- ``paper``: the paper reproduction (``quad-dob paper``).

Subpackages, by concern (each docstring says what lives there and what it may import):

- ``cli``: the ``quad-dob`` command line; imports the rest, imported by nothing.
- ``evaluation``: evaluate, metrics, statistics, margins, results, report, plots.
- ``rl``: run_config, vec_env, sb3_adapter, loop_randomization, foreign_models,
  model_files, checkpoints, run_folder.
- ``learning``: train, baseline_evaluation, sweep.
- ``tuning``: tune, the baselines' gain search.
- ``wind_tunnel``: published, tool, flight_logs, flight_statistics, plots.
- ``real_flights``: crazyflie_log, the Crazyflie's on-board log format.

Data folders: ``hyperparams/`` (rl-zoo3's schema), ``pretrained/`` (the shipped residual
policies), ``sweeps/``, ``schemas/`` (``evaluation.json``'s JSON Schema).

Before 2026-12-05 the modules sat side by side here, and before 2026-12-06 the runs sat in
``rl``; their old names (``quad_dob_training.vec_env``, ``.evaluate``, ``.rl.train``, ...)
still import, with a ``DeprecationWarning`` naming the new one (``MOVED``).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from types import ModuleType

# old module -> where it lives now
MOVED = {
    "cli_checks": "cli.checks", "listing": "cli.listing", "replay": "cli.replay",
    "evaluate": "evaluation.evaluate", "metrics": "evaluation.metrics",
    "statistics": "evaluation.statistics", "results": "evaluation.results",
    "report": "evaluation.report", "plots": "evaluation.plots",
    "margins": "evaluation.margins", "train": "learning.train", "vec_env": "rl.vec_env",
    "checkpoints": "rl.checkpoints", "run_folder": "rl.run_folder",
    "run_config": "rl.run_config", "model_files": "rl.model_files",
    "baseline_evaluation": "learning.baseline_evaluation", "sweep": "learning.sweep",
    "tune": "tuning.tune", "wind_tunnel_plots": "wind_tunnel.plots",
    "wind_tunnel_tool": "wind_tunnel.tool", "flight_logs": "wind_tunnel.flight_logs",
    "flight_statistics": "wind_tunnel.flight_statistics",
    # before 2026-12-06 the runs sat in rl, which the policies they fly now sit above
    "rl.train": "learning.train", "rl.sweep": "learning.sweep",
    "rl.baseline_evaluation": "learning.baseline_evaluation",
}


class _MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """``import quad_dob_training.vec_env`` gives ``quad_dob_training.rl.vec_env`` itself
    (the same module object, so pickles that name the old path still load)."""

    def find_spec(self, fullname: str, path: object = None,
                  target: object = None) -> importlib.machinery.ModuleSpec | None:
        package, _, old = fullname.partition(".")
        if package != __name__ or old not in MOVED:
            return None
        return importlib.machinery.ModuleSpec(fullname, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        new = f"{__name__}.{MOVED[spec.name.partition('.')[2]]}"
        warnings.warn(f"{spec.name} moved to {new}; import it from there",
                      DeprecationWarning, stacklevel=2)
        return importlib.import_module(new)

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the module came whole from its new home."""


if not any(isinstance(finder, _MovedModules) for finder in sys.meta_path):
    sys.meta_path.append(_MovedModules())
