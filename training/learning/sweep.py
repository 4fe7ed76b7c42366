"""``quad-dob sweep CONFIG.yaml``: many evaluations or trainings, locally or on Ray.

A config names a ``kind`` (``evaluate`` or ``train``), a ``grid`` (every combination) or a
``random`` draw of ``samples`` combinations from it, and ``seeds``:

```yaml
kind: evaluate
name: observer-rate-vs-wind
grid:
  policy: [geometric-ndob]          # controller names, residual, ppo:PATH, residual:PATH
  scenario: [dryden-helix]
  wind_scale: [0.25, 0.5, 0.75, 1.0]  # scales the Dryden mean wind and turbulence
  observer_rate: [1, 2, 5, 10, 20]  # NDOB decay rates [1/s], translation (rotation: 2x)
seeds: 0-9                          # each task flies all of them at once
```

``kind: train`` sweeps ``seed`` and PPO hyperparameters (``learning_rate``, ``n_steps``,
``n_epochs``, ``gamma``, ...) of ``env`` for ``timesteps``, and scores each trained model
on held-out seeds.

A task is one combination. Its result is appended to ``results.jsonl`` (one JSON line) the
moment it finishes, so a killed sweep loses only the tasks in flight and a rerun does only
the missing ones. Tasks run on a process pool of this machine, or, with ``--ray-address``
(``auto``, ``HOST:PORT`` or ``local``), as Ray tasks (``pip install 'ray>=2.9'``): the same
function on the same inputs, so the results are the same. ``summary.md``, ``summary.csv``
(mean ± std over seeds per combination) and, when the grid has two numeric axes, a heat map
are built from the lines.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from quad_dob_env import is_residual_id
from quad_dob_env.validation import unknown_name_error
from quad_dob_training.evaluation.evaluate import parse_seeds

KINDS = ("evaluate", "train")
EVALUATE_AXES = ("policy", "scenario", "wind_scale", "observer_rate")
TRAIN_AXES = ("seed", "learning_rate", "n_steps", "n_epochs", "gamma", "batch_size",
              "clip_range", "ent_coef", "gae_lambda", "thrust_scale", "moment_scale")
CONFIG_KEYS = ("kind", "name", "grid", "random", "seeds", "env", "mode", "timesteps",
               "n_envs", "scenario")


# --- the config --------------------------------------------------------------------------

SHIPPED_SWEEPS = Path(__file__).parents[1] / "sweeps"


def find_config(path: Path | str) -> Path:
    """``path`` as given, or else a shipped sweep by name or by its ``training/sweeps/``
    path, so the docs' commands work from any directory."""
    given = Path(path)
    if given.is_file():
        return given
    shipped = SHIPPED_SWEEPS / given.name
    if shipped.is_file() and (given.parent in (Path("."), Path("training/sweeps"))):
        return shipped
    raise ValueError(f"sweep config {str(path)!r} does not exist; the shipped ones are "
                     + ", ".join(sorted(p.name for p in SHIPPED_SWEEPS.glob("*.yaml"))))


def load_config(path: Path) -> dict[str, Any]:
    path = find_config(path)
    config = yaml.safe_load(Path(path).read_text())
    if not isinstance(config, dict):
        raise ValueError(f"{path} must hold a mapping with kind, grid and seeds")
    for key in config:
        if key not in CONFIG_KEYS:
            raise unknown_name_error(f"sweep config key in {Path(path).name}", key, CONFIG_KEYS)
    kind = config.get("kind", "evaluate")
    if kind not in KINDS:
        raise unknown_name_error("sweep kind", kind, KINDS)
    axes = EVALUATE_AXES if kind == "evaluate" else TRAIN_AXES
    grid = config.get("grid")
    if not isinstance(grid, dict) or not grid:
        raise ValueError(f"{path}: grid must map parameters to lists of values")
    for key, values in grid.items():
        if key not in axes:
            raise unknown_name_error(f"{kind} sweep parameter", key, axes)
        if not isinstance(values, list) or not values:
            raise ValueError(f"{path}: grid.{key} must be a non-empty list, got {values!r}")
    if kind == "evaluate":
        for key in ("policy", "scenario"):
            if key not in grid:
                raise ValueError(f"{path}: an evaluate sweep needs grid.{key}")
    elif "env" not in config:
        raise ValueError(f"{path}: a train sweep needs env (e.g. QuadDOB/TrackResidual-v1)")
    config["kind"] = kind
    config["seed_list"] = parse_seeds(config.get("seeds", "10"))
    return config


def tasks(config: dict[str, Any]) -> list[dict[str, Any]]:
    """Every combination (grid), or ``random.samples`` of them drawn with ``random.seed``."""
    keys = list(config["grid"])
    combinations = [dict(zip(keys, values, strict=True))
                    for values in itertools.product(*(config["grid"][k] for k in keys))]
    sampling = config.get("random")
    if sampling:
        rng = np.random.default_rng(int(sampling.get("seed", 0)))
        count = min(int(sampling["samples"]), len(combinations))
        chosen = sorted(rng.choice(len(combinations), count, replace=False))
        combinations = [combinations[i] for i in chosen]
    shared = {k: config[k] for k in ("kind", "env", "mode", "timesteps", "n_envs", "scenario")
              if k in config}
    return [{**shared, "params": params, "seeds": config["seed_list"], "id": task_id(params)}
            for params in combinations]


def task_id(params: dict[str, Any]) -> str:
    return hashlib.sha1(json.dumps(params, sort_keys=True).encode()).hexdigest()[:12]


# --- one task ----------------------------------------------------------------------------

def run_task(task: dict[str, Any]) -> dict[str, Any]:
    """Run one task where it lands (this process, a pool worker or a Ray worker)."""
    runner = _evaluate_task if task["kind"] == "evaluate" else _train_task
    return {"id": task["id"], "params": task["params"], **runner(task)}


def _evaluate_task(task: dict[str, Any]) -> dict[str, Any]:
    from quad_dob_env.scenarios import make_scenario
    from quad_dob_training.evaluation.metrics import flight_metrics
    from quad_dob_training.policies import Policy, fly_policy, make_policy

    params = task["params"]
    options = {} if params.get("wind_scale") is None else {"wind_scale": params["wind_scale"]}
    scenario = make_scenario(params["scenario"], **options)
    # bare residual: the shipped policy of the benchmark the scenario flies
    policy = make_policy(params["policy"], benchmark=scenario.loop.benchmark)
    rate = params.get("observer_rate")
    if rate is not None:
        policy = Policy(f"{policy.name}@{rate}", _observer_controller(params["policy"], rate,
                                                                      scenario.vehicle),
                        policy.model, policy.config)
    metrics = [flight_metrics(f) for f in fly_policy(policy, scenario, task["seeds"])]
    return _scores(metrics)


def _observer_controller(name: str, rate: float, vehicle) -> Any:
    from quad_dob_baselines import GeometricController, NonlinearDisturbanceObserver

    if not name.startswith("geometric-ndob"):
        raise ValueError(f"observer_rate applies to geometric-ndob policies, not {name!r}")
    return GeometricController(observer=NonlinearDisturbanceObserver.from_rates(
        float(rate), 2.0 * float(rate), vehicle))


def _train_task(task: dict[str, Any]) -> dict[str, Any]:
    import tempfile

    from quad_dob_env.scenarios import make_scenario
    from quad_dob_training.evaluation.metrics import flight_metrics
    from quad_dob_training.learning.train import train
    from quad_dob_training.policies import Policy, fly_policy, trained_benchmark
    from quad_dob_training.rl.run_config import resolve_config

    params = dict(task["params"])
    seed = int(params.pop("seed", 0))
    mode = task.get("mode", "residual" if is_residual_id(task["env"]) else "direct")
    config = resolve_config("ppo", mode, task["env"], task.get("scenario"),
                            task.get("timesteps"), task.get("n_envs"), seed)
    for key, value in params.items():
        if key in ("thrust_scale", "moment_scale"):
            config["env_kwargs"][key] = value
        else:
            config["algo_kwargs"][key] = value
    with tempfile.TemporaryDirectory() as folder:
        model = train(config, Path(folder), evaluate_every=10**12, progress_bar=False)
    policy = Policy("trained", config["base_controller"], model, config)
    # scored in the loop it trained in (a -v2 or -v3 id's benchmark), on its scenario
    scenario = make_scenario(config["env_kwargs"]["scenario"],
                             benchmark=trained_benchmark(config))
    metrics = [flight_metrics(f) for f in fly_policy(policy, scenario, task["seeds"])]
    return _scores(metrics)


def _scores(metrics: list[dict]) -> dict[str, Any]:
    return {"rms_position": [m["rms_position_settled"] for m in metrics],
            "rms_attitude": [m["rms_attitude_settled"] for m in metrics],
            "crashed": [bool(m["crashed"]) for m in metrics]}


# --- running and resuming ----------------------------------------------------------------

def finished(path: Path) -> dict[str, dict]:
    """Results already written, by task id; a line cut off by a kill is dropped (and the file
    rewritten without it)."""
    if not path.exists():
        return {}
    results, lines = {}, path.read_text().splitlines()
    for line in lines:
        try:
            result = json.loads(line)
        except json.JSONDecodeError:
            continue
        results[result["id"]] = result
    if len(results) != len(lines):
        path.write_text("".join(json.dumps(r) + "\n" for r in results.values()))
    return results


def _append(path: Path, result: dict) -> None:
    with open(path, "a") as file:
        file.write(json.dumps(result) + "\n")
        file.flush()
        os.fsync(file.fileno())


def run_local(pending: list[dict], on_result: Callable[[dict], None], workers: int) -> None:
    if workers <= 1 or len(pending) <= 1:
        for task in pending:
            on_result(run_task(task))
        return
    context = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
    with ProcessPoolExecutor(workers, mp_context=context) as pool:
        running = {pool.submit(run_task, task) for task in pending}
        while running:
            done, running = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                on_result(future.result())


def run_ray(pending: list[dict], on_result: Callable[[dict], None], address: str,
            num_cpus: int | None = None) -> None:
    try:
        import ray
    except ImportError:
        # the project is not on a package index: its extra only installs inside a checkout
        raise ValueError("--ray-address needs Ray: pip install 'ray>=2.9'") from None
    started_here = not ray.is_initialized()
    if started_here:
        if address == "local":
            ray.init(num_cpus=num_cpus, include_dashboard=False, log_to_driver=False)
        else:
            try:
                ray.init(address=address, log_to_driver=False)
            except ConnectionError:
                raise ValueError(
                    f"--ray-address {address}: no Ray cluster answers there; start "
                    "one with `ray start --head`, give its HOST:PORT, or use --ray-address "
                    "local to run the sweep on a Ray instance of this machine") from None
    try:
        remote = ray.remote(run_task)
        running = [remote.remote(task) for task in pending]
        while running:
            done, running = ray.wait(running, num_returns=1)
            for reference in done:
                on_result(ray.get(reference))
    finally:
        if started_here:  # a caller's own Ray session stays; ours leaves no workers behind
            ray.shutdown()


def run_sweep(config_path: Path, out: Path | None = None, ray_address: str | None = None,
              workers: int | None = None, limit: int | None = None) -> list[dict]:
    """Run the sweep's missing tasks (at most ``limit``), then summarise every result."""
    config = load_config(config_path)
    out = Path(out or Path("results") / "sweeps" / config.get("name", Path(config_path).stem))
    out.mkdir(parents=True, exist_ok=True)
    results_path = out / "results.jsonl"
    done = finished(results_path)
    all_tasks = tasks(config)
    pending = [task for task in all_tasks if task["id"] not in done][:limit]
    print(f"{len(all_tasks)} tasks, {len(done)} already done, running {len(pending)}"
          + (f" on Ray ({ray_address})" if ray_address else ""))

    def on_result(result: dict) -> None:
        _append(results_path, result)
        done[result["id"]] = result

    if ray_address:
        run_ray(pending, on_result, ray_address, workers)
    else:
        run_local(pending, on_result, workers or os.cpu_count() or 1)
    rows = summarise([done[t["id"]] for t in all_tasks if t["id"] in done], config, out)
    return rows


# --- the summary -------------------------------------------------------------------------

def summarise(results: list[dict], config: dict, out: Path) -> list[dict]:
    rows = []
    for result in results:
        rms = np.array(result["rms_position"])
        rows.append({**result["params"], "rms_position_mean": float(rms.mean()),
                     "rms_position_std": float(rms.std()),
                     "rms_attitude_mean": float(np.mean(result["rms_attitude"])),
                     "crash_rate": float(np.mean(result["crashed"])), "seeds": len(rms)})
    if not rows:
        return rows
    keys = list(rows[0])
    with open(out / "summary.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    params = list(config["grid"])
    lines = ["| " + " | ".join(params) + " | RMS ‖e_x‖, t≥2 s [m] | crash rate |",
             "|" + "---|" * (len(params) + 2)]
    for row in rows:
        lines.append("| " + " | ".join(str(row[p]) for p in params)
                     + f" | {row['rms_position_mean']:.4f} ± {row['rms_position_std']:.4f}"
                     f" | {row['crash_rate']:.0%} |")
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    numeric = [p for p in params if len(config["grid"][p]) > 1
               and all(isinstance(v, (int, float)) for v in config["grid"][p])]
    if len(numeric) >= 2:
        heat_map(rows, numeric[0], numeric[1], out / "heatmap.png")
    print("\n".join(lines))
    return rows


def heat_map(rows: list[dict], x_key: str, y_key: str, path: Path) -> None:
    """Mean RMS position error over two numeric parameters (the other axes averaged)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs = sorted({row[x_key] for row in rows})
    ys = sorted({row[y_key] for row in rows})
    grid = np.full((len(ys), len(xs)), np.nan)
    for j, y in enumerate(ys):
        for i, x in enumerate(xs):
            values = [r["rms_position_mean"] for r in rows if r[x_key] == x and r[y_key] == y]
            if values:
                grid[j, i] = np.mean(values)
    figure, axis = plt.subplots(figsize=(1.2 + 1.1 * len(xs), 1.0 + 0.55 * len(ys)))
    image = axis.imshow(grid, origin="lower", cmap="viridis", aspect="auto")
    for j, i in itertools.product(range(len(ys)), range(len(xs))):
        if np.isfinite(grid[j, i]):
            axis.text(i, j, f"{grid[j, i]:.3f}", ha="center", va="center", fontsize=8,
                      color="white" if grid[j, i] > np.nanmean(grid) else "black")
    axis.set_xticks(range(len(xs)), [str(x) for x in xs])
    axis.set_yticks(range(len(ys)), [str(y) for y in ys])
    axis.set_xlabel(x_key)
    axis.set_ylabel(y_key)
    figure.colorbar(image, label="RMS position error, t ≥ 2 s [m]")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)

