"""Policies by name, and flying them over many seeds at once.

A policy is what ``quad-dob evaluate --policies`` names:

| spec                | what flies                                                       |
|---------------------|------------------------------------------------------------------|
| ``geometric-ndob``  | that controller alone (any ``baselines`` controller name)        |
| ``py:pkg.mod:Name`` | a user's controller (or a name an installed package registers)   |
| ``ppo:PATH``        | a PPO model from ``quad-dob train``, direct or residual as its   |
|                     | config says; ``sac:PATH``, ``td3:PATH`` the same for SAC, TD3    |
|                     | (PATH a zip or its run folder). A zip saved by SB3 or rl-zoo3    |
|                     | with no config beside it takes ``env_id`` (``--env ID``), the id |
|                     | it was trained on (``rl.foreign_models``)                        |
| ``residual``        | the newest shipped residual policy trained in the benchmark      |
|                     | being flown (the scenario's ``benchmark``): ``residual:v1`` in   |
|                     | v1, ``residual:v2`` in v2, ``residual:v3`` in v3; the newest one |
|                     | overall in a benchmark none was trained in (``resolve_spec``)    |
| ``residual:v1``     | the shipped policy trained in Benchmark v1's ideal loop          |
|                     | (``training/pretrained``), on its base                           |
| ``residual:v2``     | the shipped policy trained in Benchmark v2's loop (issue 29)     |
| ``residual:v3``     | the shipped policy trained in Benchmark v3's loop (issue 42)     |
| ``residual:PATH``   | a residual model from ``quad-dob train --mode residual``         |
| ``oracle:NAME``     | the loop's floor: NAME (a geometric base with an observer) fed   |
|                     | the simulator's true disturbance (``composition/oracle.py``)     |

Results name the policy bare ``residual`` resolved to (``residual:v2``); rows written
before it followed the benchmark named bare ``residual`` v1's policy, as their
``policy_fingerprint`` (the zip's sha256) says.

The shipped policies' zips and their configs (base controller, env options, observation
statistics) are checked against ``SHIPPED_RESIDUAL_SHA256`` and
``SHIPPED_RESIDUAL_CONFIG_SHA256`` (v2, v3: ``SHIPPED_RESIDUAL_V2_*``,
``SHIPPED_RESIDUAL_V3_*``) before either is read.

Every policy flies in a ``QuadrotorVectorEnv`` with one vehicle per seed: a controller is
the base of a residual env given zero residuals (which flies it exactly), a residual model
adds its actions to its base, a direct model commands the vehicle itself. The records are
``quad_dob_training.rollout.Flight``s, so ``quad-dob evaluate`` scores them with the same
metric code as ``quad-dob paper``. A request whose records would pass the memory budget
(``quad_dob_env.memory``; ``rollout.RECORD_BYTES_PER_STEP`` a vehicle and step) is refused before
anything is built.

Model files (``ALGO:PATH``, ``residual:PATH``, the shipped one) are loaded by
``quad_dob_training.rl.model_files`` without unpickling anything, because unpickling runs
whatever code the file's author put in it: the pickled entries of the zip's JSON (spaces,
policy class, schedules, training buffers) are rebuilt from the config beside it and the env
that config describes, and the weights are read as tensors only (torch's
``weights_only=True``). A zip with a pickled entry that cannot be rebuilt is refused unless
``trust_pickle=True`` (``--trust-pickle``), which unpickles the zip's entries as
stable-baselines3 does; so does ``model_files.load_zip``, which ``quad-dob train --resume``
uses for a run's own checkpoints.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_baselines import (
    Controller,
    controller_names,
    is_controller_name,
    make_controller,
    user_controller,
)
from quad_dob_composition import make_vector_env
from quad_dob_composition.oracle import is_oracle_name
from quad_dob_env.envs import QuadrotorVectorEnv
from quad_dob_env.flatness import flat_attitude
from quad_dob_env.scenarios import Scenario
from quad_dob_env.validation import unknown_name_error
from quad_dob_training.rl.model_files import (
    ALGORITHMS,
    SHIPPED_RESIDUAL,
    SHIPPED_RESIDUAL_CONFIG_SHA256,
    SHIPPED_RESIDUAL_SHA256,
    SHIPPED_RESIDUAL_V2,
    SHIPPED_RESIDUAL_V2_CONFIG_SHA256,
    SHIPPED_RESIDUAL_V2_SHA256,
    SHIPPED_RESIDUAL_V3,
    SHIPPED_RESIDUAL_V3_CONFIG_SHA256,
    SHIPPED_RESIDUAL_V3_SHA256,
    SHIPPED_RESIDUAL_V4,
    SHIPPED_RESIDUAL_V4_CONFIG_SHA256,
    SHIPPED_RESIDUAL_V4_SHA256,
    config_env_options,
    load_model,
    model_zip,
    sha256,
)
from quad_dob_training.rollout import Flight, FlightRecorder, check_flight_memory

# the shipped residual policies by the benchmark they were trained in, oldest first, each
# its zip, the zip's sha256 and its config's: ``residual:v1`` to ``residual:v4`` (bare
# ``residual``: the one of the benchmark flown, ``resolve_spec``)
SHIPPED_POLICIES = {
    "v1": (SHIPPED_RESIDUAL, SHIPPED_RESIDUAL_SHA256, SHIPPED_RESIDUAL_CONFIG_SHA256),
    "v2": (SHIPPED_RESIDUAL_V2, SHIPPED_RESIDUAL_V2_SHA256, SHIPPED_RESIDUAL_V2_CONFIG_SHA256),
    "v3": (SHIPPED_RESIDUAL_V3, SHIPPED_RESIDUAL_V3_SHA256, SHIPPED_RESIDUAL_V3_CONFIG_SHA256),
    "v4": (SHIPPED_RESIDUAL_V4, SHIPPED_RESIDUAL_V4_SHA256, SHIPPED_RESIDUAL_V4_CONFIG_SHA256),
}


@dataclass
class Policy:
    """``name`` for tables; ``base`` a controller name, a ``Controller`` (as ``quad-dob tune``
    flies its candidates) or None; ``model`` an SB3 model (or None for a controller alone);
    ``config`` the training config saved beside the model."""

    name: str
    base: Any
    model: Any = None
    config: dict | None = None
    # the benchmark whose gains a residual model's base was trained with (None: the
    # scenario's own, for a controller flown alone)
    base_benchmark: str | None = None
    # sha256 of what a result names beyond the project's own code: the model file, or a
    # py: controller's module (None: a built-in controller, named by the project version)
    fingerprint: str | None = None

    def act(self, observations: NDArray[np.float32]) -> NDArray:
        """Deterministic actions for (N, obs) observations, normalised as in training."""
        normalization = (self.config or {}).get("observation_normalization")
        if normalization is not None:
            mean = np.asarray(normalization["mean"])
            scale = np.sqrt(np.asarray(normalization["var"]) + normalization["epsilon"])
            clip = normalization["clip"]
            observations = np.clip((observations - mean) / scale, -clip, clip).astype(np.float32)
        actions, _ = self.model.predict(observations, deterministic=True)
        return actions

    def refusal(self, scenario: Scenario) -> str | None:
        """Why its controller cannot fly ``scenario``'s control step, actuation and vehicle
        (``Controller.refusal``: RAPTOR's 10 ms and rotors), or None; asked before any
        flight, so a long evaluation does not stop halfway."""
        if isinstance(self.base, Controller):  # as quad-dob tune flies its candidates
            controller = self.base
        elif is_controller_name(self.base):
            controller = make_controller(self.base, scenario.vehicle,
                                         self.base_benchmark or scenario.loop.benchmark)
        else:
            return None
        return controller.refusal(scenario.dt, scenario.actuation, scenario.vehicle)

    def env_kwargs(self) -> dict[str, Any]:
        """The env options the model was trained with (its spaces depend on them), less
        what chooses the flight: the scenario, its options and the benchmark are the
        evaluation's. A model's ``benchmark`` passed on would rebuild the scenario in the
        loop it was trained in, so ``residual:v2`` asked to fly v3 flew v2's loop under a
        v3 label; its base keeps the gains of its training benchmark (``base_benchmark``)."""
        if self.config is None:
            return {"base_controller": self.base}
        options = config_env_options(self.config)
        for flight_choice in ("scenario", "scenario_options", "benchmark"):
            options.pop(flight_choice, None)
        options["base_controller"] = self.base
        if self.base is not None and self.base_benchmark is not None:
            options["base_benchmark"] = self.base_benchmark
        return options


# the benchmark a scenario flies when none is named (the default of the Scenario record's
# loop)
LIBRARY_BENCHMARK: str = next(field.default for field in dataclasses.fields(Scenario)
                              if field.name == "loop").benchmark


def resolve_spec(spec: str, benchmark: str | None = None) -> str:
    """``spec`` as it is flown in ``benchmark`` (None: the library's default, v1): bare
    ``residual`` is the newest shipped policy trained in that benchmark (``residual:v2`` in
    v2), or the newest shipped overall where none was trained there; any other spec is
    itself."""
    if spec != "residual":
        return spec
    benchmark = benchmark or LIBRARY_BENCHMARK
    return f"residual:{benchmark if benchmark in SHIPPED_POLICIES else list(SHIPPED_POLICIES)[-1]}"


# the loop each shipped policy learnt to correct, for the advice the tools print
SHIPPED_TRAINED_IN = {
    "v1": "Benchmark v1's ideal loop (the true state, no lag)",
    "v2": "Benchmark v2's loop (sensing, latency, motor lag)",
    "v3": "Benchmark v3's loop (the real vehicle's lag and thrust path)",
    "v4": "Benchmark v4's loop (the estimators told the command, the tunnel's drag and vibration)",
}


def shipped_policy_advice(benchmark: str, rows: Sequence[dict] = ()) -> str:
    """Which shipped residual policy to fly in ``benchmark``, and why, in at most three lines
    (the demo's console and report.html say it): the choice; with ``rows`` (an evaluation's
    results), the chosen policy's own rows, against the baseline where there is one; and,
    where another shipped policy scores lower on a row, that row with why it is still not
    the choice. The why is measured: docs/research/transfer-between-benchmarks.md."""
    chosen = resolve_spec("residual", benchmark)
    version = chosen.partition(":")[2]
    if version == benchmark:
        why = f"it was trained in {SHIPPED_TRAINED_IN[version]}, the loop flown here"
    else:
        why = (f"no shipped policy was trained in Benchmark {benchmark}, and it is the newest "
               f"(trained in {SHIPPED_TRAINED_IN[version]})")
    lines = [f"Which shipped policy to use in Benchmark {benchmark}: {chosen}, which bare "
             f"'residual' names, because {why}."]
    error = "rms_position_settled_mean"
    mine = {row["scenario"]: row for row in rows if row.get("policy") == chosen
            and error in row}
    if mine:
        cells = []
        for scenario, row in mine.items():
            cell = f"{scenario} {1e3 * row[error]:.1f} mm"
            baseline = row.get("baseline")
            compared = next((other for other in rows if other.get("scenario") == scenario
                             and other.get("policy") == baseline and error in other), None)
            if compared is not None and baseline != chosen and compared[error] > 0:
                change = 100 * (row[error] / compared[error] - 1)
                cell += f" ({change:+.0f} % against {baseline})"
            cells.append(cell)
        lines.append(f"Its rows: {'; '.join(cells)}.")
    shipped = {f"residual:{name}" for name in SHIPPED_POLICIES} - {chosen}
    lower = [row for row in rows if row.get("scenario") in mine and error in row
             and row.get("policy") in shipped and row[error] < mine[row["scenario"]][error]]
    if lower:
        lines.append("Lower on a row, still not the choice: " + "; ".join(
            f"{row['policy']} on {row['scenario']} ({1e3 * row[error]:.1f} mm), trained in "
            f"another loop, flies here on its own benchmark's gains: a transfer"
            for row in lower) + " (docs/research/transfer-between-benchmarks.md).")
    else:
        lines.append("The other shipped policies were trained in other loops: a lower error "
                     "from one of them is a transfer, not a recommendation "
                     "(docs/research/transfer-between-benchmarks.md).")
    return "\n".join(lines)


def make_policy(spec: str, *, trust_pickle: bool = False, env_id: str | None = None,
                benchmark: str | None = None) -> Policy:
    """The policy a ``--policies`` entry names (see the module docstring); ``trust_pickle``
    lets ``ALGO:PATH`` / ``residual:PATH`` unpickle their zips (``load_model``). The shipped
    policies are always loaded checked and without unpickling. ``env_id``: the id a model
    zip with no training config beside it was trained on (``--env``; ignored for models
    with their config). ``benchmark``: the one flown, which bare ``residual`` follows
    (``resolve_spec``); the policy is named as resolved."""
    spec = resolve_spec(spec, benchmark)
    kind, _, path = spec.partition(":")
    if is_oracle_name(spec):  # the loop's floor: a base fed the true disturbance
        return Policy(spec, base=spec)
    if is_controller_name(spec):
        user = user_controller(spec)  # a py: module that does not import fails here, named
        return Policy(spec, base=spec, fingerprint=None if user is None else
                      _source_sha256(user[1]))
    if kind == "residual" and path in SHIPPED_POLICIES:
        zip_path, digest, config_digest = SHIPPED_POLICIES[path]
        model, config = load_model(zip_path, digest, expected_config_sha256=config_digest)
        return Policy(spec, config["base_controller"], model, config,
                      trained_benchmark(config), digest)
    if (kind in ALGORITHMS or kind == "residual") and path:
        if kind == "residual" and not Path(path).exists():
            # "residual:v9" reads as a shipped name more often than as a missing file
            shipped = ", ".join(f"residual:{name}" for name in SHIPPED_POLICIES)
            raise ValueError(f"{spec!r} names no shipped policy ({shipped}, and bare "
                             f"'residual') and no file or run folder {path!r}: give one of "
                             "those, or the path of a model .zip or its run folder")
        model, config = load_model(path, trust_pickle=trust_pickle, env_id=env_id, kind=kind)
        options = config_env_options(config)
        algo = config.get("algo", "ppo")
        mode = config.get("mode") or ("residual" if options.get("base_controller") else "direct")
        if kind == "residual" and mode != "residual":
            raise ValueError(f"{spec!r}: the model at {path} was trained in mode {mode!r}, "
                             "not 'residual'")
        if kind in ALGORITHMS and kind != algo:
            raise ValueError(f"{spec!r}: the model at {path} was trained with {algo} (its "
                             f"config says so), not {kind}: name it {algo}:{path}")
        base = options.get("base_controller") if mode == "residual" else None
        zip_path = model_zip(path)
        return Policy(f"{kind}:{row_name(Path(path))}", base, model, config,
                      trained_benchmark(config) if base is not None else None,
                      sha256(zip_path))
    raise unknown_name_error("policy", spec, [
        *controller_names(), "py:package.module:Name", "oracle:NAME",
        *(f"{algo}:PATH" for algo in ALGORITHMS), "residual",
        *(f"residual:{name}" for name in SHIPPED_POLICIES), "residual:PATH"])


def _source_sha256(found: object) -> str | None:
    """sha256 of the file a user's controller is defined in (None if it has none)."""
    import inspect

    try:
        source = inspect.getsourcefile(found)
    except TypeError:
        return None
    return sha256(Path(source)) if source else None


def trained_benchmark(config: dict) -> str:
    """The benchmark a model was trained in, from its config's env options (a ``-v2`` id's
    ``benchmark``, or its scenario options'); v1 when neither says, as for every model
    saved before Benchmark v2. A residual's base flies that benchmark's gains wherever the
    model is evaluated: the base it learnt to correct."""
    env_kwargs = config_env_options(config)  # a hand-written config's id's too
    options = env_kwargs.get("scenario_options") or {}
    return str(options.get("benchmark", env_kwargs.get("benchmark") or "v1"))


def row_name(path: Path) -> str:
    """A model's name in a results row: ``runs/wind/model.zip`` -> ``wind``;
    ``runs/wind/ppo_200000_steps.zip`` -> that stem; rl-zoo3's
    ``logs/ppo/QuadDOB-Hover-v3_2/QuadDOB-Hover-v3.zip`` -> ``QuadDOB-Hover-v3_2``, its run
    folder, since every run of one id saves a zip of the same name."""
    if path.suffix != ".zip":
        return path.name
    run = path.parent.name
    if path.stem in ("model", "best_model"):
        return run
    stem, _, number = run.rpartition("_")
    return run if stem == path.stem and number.isdigit() else path.stem


def check_spaces(policy: Policy, env: QuadrotorVectorEnv) -> None:
    """Fail before any step when the model's spaces do not fit the env, naming both."""
    if policy.model is None:
        return
    model_obs, env_obs = policy.model.observation_space, env.single_observation_space
    model_act, env_act = policy.model.action_space, env.single_action_space
    if model_obs.shape != env_obs.shape or model_act.shape != env_act.shape:
        raise ValueError(
            f"policy {policy.name!r} expects observations {model_obs.shape} and actions "
            f"{model_act.shape} (trained on {policy.config.get('env_id')} in mode "
            f"{policy.config.get('mode')!r}), but the env gives observations "
            f"{env_obs.shape} and takes actions {env_act.shape}")


def fly_policy(policy: Policy, scenario: Scenario, seeds: list[int]) -> list[Flight]:
    """One episode per seed, all flown together; records stop at each episode's end.
    Refused at once when the records would pass the memory budget (``check_flight_memory``).
    """
    n = len(seeds)
    check_flight_memory(n, scenario.steps, f"flying {scenario.name!r}")
    env = make_vector_env(n, scenario, **policy.env_kwargs())
    check_spaces(policy, env)
    obs, _ = env.reset(seed=[int(s) for s in seeds])
    core, residual = env.core, env.residual
    # an acceleration residual's base runs within the step, from the state before it: its
    # desired attitude and estimates for that state are there after the step, not before
    planned_in_step = residual is not None and residual.residual_mode == "acceleration"
    recorder = FlightRecorder(n, core.vehicle)
    zeros = np.zeros((n, 3))
    for _ in range(scenario.steps):
        actions = np.zeros((n, 4)) if policy.model is None else policy.act(obs)
        state, reference = core.state.copy(), core.reference
        measured = core.measurement.estimate.copy()  # what the policy flies on, before it
        # the base moment this step's command adds to (the plan overwrites it in the step)
        planned = None if residual is None or planned_in_step else residual.base_moment.copy()
        if not planned_in_step:
            desired, estimates = _diagnostics(core, residual, zeros)
        obs, _, terminated, truncated, _ = env.step(actions)
        if planned_in_step:
            desired, estimates = _diagnostics(core, residual, zeros)
        requested, requested_moment = (residual.requested_command(planned)
                                       if residual is not None
                                       else core.action_map.to_command(actions))
        if not recorder.add(
                state, terminated | truncated, core.termination_reason,
                time=core.time - scenario.dt, reference_position=reference.position,
                reference_velocity=reference.velocity,
                reference_acceleration=reference.acceleration, desired_rotation=desired,
                requested_thrust=requested, requested_moment=requested_moment,
                applied_thrust=core.applied.thrust,
                applied_moment=core.applied.moment, disturbance_force=core.disturbance_force,
                disturbance_torque=core.disturbance_torque, force_estimate=estimates[0],
                torque_estimate=estimates[1], estimated_position=measured.position,
                estimated_velocity=measured.velocity, estimated_rotation=measured.rotation):
            break
    return recorder.flights([scenario] * n, policy.name, scenario.dt)


def _diagnostics(core, residual, zeros: NDArray) -> tuple[NDArray, tuple[NDArray, NDArray]]:
    """The base's desired attitude (the flat one without a base) and its observer's force
    and torque estimates, copied."""
    diagnostics = residual.controller.diagnostics if residual is not None else {}
    desired = diagnostics.get("desired_rotation")
    if desired is None:
        desired = _flat_attitude(core)
    return desired.copy(), (diagnostics.get("force_estimate", zeros).copy(),
                            diagnostics.get("torque_estimate", zeros).copy())


def _flat_attitude(core) -> NDArray:
    """For a policy with no controller: the attitude that flies the reference exactly."""
    return flat_attitude(core.reference, core.vehicle.mass, core.vehicle.gravity).rotation
