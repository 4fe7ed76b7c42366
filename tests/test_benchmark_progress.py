"""Every script in benchmarks/ that runs over 10 s reports its progress on standard error
(issue 57): a first line at once saying what it will do, then a line per unit of work done
(``quad_dob_training.progress``; in a log, where capsys is not a terminal). Each script runs
here with a stub of its work, so that only its reporting is under test."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from quad_dob_training.policies import Policy

BENCHMARKS = Path(__file__).parents[1] / "benchmarks"

# scripts without progress, each measured under 10 s on the project's 2-core machine with its
# default arguments (the table readers on an evaluation folder), or not a script at all
UNDER_10_S = {
    "loop_table": "0.1 s: reads six evaluation.csv files",
    "sensing_table": "0.1 s: reads three evaluation.csv files",
    "suite_table": "2.1 s (2.4 s with --strongest): reads one evaluation.csv",
    "wind_tunnel_table": "2.7 s: reads seven evaluation.csv files",
    "variants": "a module the table readers import, not a script",
}


def _identity(scenario, *_, **__):
    return scenario


# each script's stubs: (monkeypatch, module) -> None, with the arguments it is run with and
# what its standard error must hold: its first line's start, then lines in that order
def _gain_set_delay_margins(mp, module):
    margin = SimpleNamespace(margin=0.02, describe=lambda: "20 ms")
    mp.setattr(module, "delay_margin", lambda *_, **__: margin)
    mp.setattr(module, "tuning_scenario", lambda name, *_: name)
    mp.setattr(module, "warm_up_copy", _identity)
    mp.setattr(module, "fly_policy", lambda *_: [])


def _gate_under_noise(mp, module):
    mp.setattr(module, "make_policy", lambda spec, **_: Policy(f"{spec}:v1", "pid"))
    mp.setattr(module, "open_share", lambda *_, **__: (0.5, 0.25))


class _FakeL2FChild:
    def __init__(self, threads):
        self.threads = threads

    def measure(self, n, mode, steps, seconds=None):
        return {"rate": 1e6, "dt": 0.01, "steps": steps, "reset_share": 0.0}

    def close(self):
        pass


def _l2f_speed(mp, module):
    mp.setattr(module, "load_l2f", lambda: SimpleNamespace(vector_selector={1: None, 2: None},
                                                           __file__="/site/l2f/__init__.py"))
    mp.setattr(module, "hold_to_cores", lambda cores: cores)
    mp.setattr(module, "warm_up", lambda: None)
    mp.setattr(module, "L2FChild", _FakeL2FChild)
    mp.setattr(module, "our_env", lambda *_: None)
    mp.setattr(module, "compiled_and_warm", lambda _: None)
    mp.setattr(module, "flown", lambda _: (0.01, True))
    mp.setattr(module, "timed_env_steps_per_second", lambda *_: 1e5)


def _landings_under_margin(mp, module):
    mp.setattr(module, "make_policy", lambda spec, **_: Policy(spec, spec))
    mp.setattr(module, "make_scenario", lambda name, **_: SimpleNamespace(name=name, dt=0.01))
    mp.setattr(module, "warm_up_copy", _identity)
    mp.setattr(module, "reference_kinds", lambda _, seeds: ["landing"] * len(seeds))
    mp.setattr(module, "fly_policy", lambda _, __, seeds: [SimpleNamespace()] * len(seeds))
    mp.setattr(module, "flight_metrics", lambda _: {"crashed": False})


class _FakeRenderEnv:
    """A rendering env of 250 steps at 100 frames a second (3 units of a second)."""

    def __init__(self) -> None:
        self.metadata = {"render_fps": 100}
        self.unwrapped = self
        self.scenario = SimpleNamespace(steps=250)
        self.count = 0

    def reset(self, seed=None):
        self.count = 0
        return np.zeros(3), {}

    def step(self, action):
        self.count += 1
        return np.zeros(3), 0.0, False, self.count >= self.scenario.steps, {}

    def render(self):
        return None

    def close(self):
        return None


def _render_speed(mp, module):
    mp.setattr(module, "gym", SimpleNamespace(
        make=lambda *_, **__: _FakeRenderEnv(),
        wrappers=SimpleNamespace(RecordVideo=lambda env, *_, **__: env)))
    mp.setattr(module, "ReferencePolicy",
               lambda *_: SimpleNamespace(predict=lambda obs: (np.zeros(4), None)))


def _residual_in_its_loop(mp, module):
    mp.setattr(module, "load", lambda run: Policy(f"residual:{run}", "pid"))
    mp.setattr(module, "fly", lambda *_, **__: module.Flown(0.01, 0.1, 0.0, 0.2))


def _residual_room(mp, module):
    mp.setattr(module, "settled_rms", lambda *_, **__: 0.01)
    mp.setattr(module, "make_scenario", lambda *_, **__: SimpleNamespace(dt=0.01))


def _residual_vs_strongest(mp, module):
    mp.setattr(module, "make_policy", lambda spec, **_: Policy(spec, "geometric-ndob:tuned"))
    calls = []

    def evaluate(specs, scenarios, seeds, per_seed, **options):
        calls.append(options)
        for spec in specs:
            per_seed[scenarios[0], spec] = [
                {"rms_position_settled": 0.01 + 0.001 * k, "crashed": False,
                 "rms_command_rate": 10.0} for k in range(len(seeds))]
        return []

    mp.setattr(module, "evaluate", lambda specs, scenarios, seeds, baseline=None, per_seed=None,
               **options: evaluate(specs, scenarios, seeds, per_seed, **options))
    module.evaluate_calls = calls


def _side_by_side(mp, module):
    mp.setattr(module, "installed", lambda commit, workdir, say=print: Path(commit))
    mp.setattr(module, "measure", lambda *_: {"rate": 1e5, "module": "quad_dob_env"})


def _side_by_side_one_cannot_fly(mp, module):
    mp.setattr(module, "installed", lambda commit, workdir, say=print: Path(commit))

    def measure(python, case, steps, cwd):
        if python == Path("old"):
            raise RuntimeError("failed:\nno such id")
        return {"rate": 1e5, "module": "quad_dob_env"}

    mp.setattr(module, "measure", measure)


class _FakeVectorEnv:
    def __init__(self, n, *_, **__) -> None:
        self.n = n

    def reset(self, seed=None):
        return np.zeros((self.n, 3)), {}

    def step(self, actions):
        ended = np.zeros(self.n, bool)
        return np.zeros((self.n, 3)), np.zeros(self.n), ended, ended, {}


def _soak(mp, module):
    mp.setattr(module, "ResidualVectorEnv", _FakeVectorEnv)


def _supervisor_signals(mp, module):
    mp.setattr(module, "fly", lambda *_, **__: {
        "signals": np.full((10, 3), 1.5), "factors": np.ones(10), "lost": 0, "own": False})


def _throughput(mp, module):
    mp.setattr(module, "warm_up", lambda: None)
    for name in ("single_env_steps_per_second", "batch_steps_per_second",
                 "vector_env_steps_per_second", "timed_env_steps_per_second"):
        mp.setattr(module, name, lambda *_, **__: 1e6)
    mp.setattr(module, "vector_env", lambda *_, **__: None)
    mp.setattr(module, "ResidualVectorEnv", lambda *_, **__: None)
    mp.setattr(module, "compiled_and_warm", lambda _: None)
    mp.setattr(module, "memory_per_env", lambda *_: 4096.0)


class _FakeModel:
    """Learns in iterations of ``per_rollout`` timesteps, calling the callback's hooks."""

    per_rollout = 500

    def learn(self, total, reset_num_timesteps=True, callback=None):
        for _ in range(-(-total // self.per_rollout)):
            if callback is not None:
                callback.on_rollout_start()
                callback.on_rollout_end()


def _training_speed(mp, module):
    config = {"n_envs": 10, "algo_kwargs": {"n_steps": 50, "batch_size": 100},
              "env_kwargs": {"scenario": "random-tracks"}, "base_controller": "pid"}
    mp.setattr(module, "resolve_config", lambda *_, **__: config)
    venv = SimpleNamespace(num_envs=10, action_space=SimpleNamespace(shape=(4,),
                                                                     dtype=np.float32),
                           reset=lambda: None, step=lambda actions: None,
                           step_wait=lambda: None)
    mp.setattr(module, "make_vec_env", lambda _: venv)
    mp.setattr(module, "make_model", lambda *_: _FakeModel())
    mp.setattr(module.torch, "set_num_threads", lambda _: None)


def _transfer_bases(mp, module):
    mp.setattr(module, "make_policy", lambda spec, **_: Policy(spec, "pid", base_benchmark="v2"))
    mp.setattr(module, "make_scenario", lambda name, **_: name)
    mp.setattr(module, "warm_up_copy", _identity)
    mp.setattr(module, "fly_policy", lambda *_: [])
    mp.setattr(module, "settled_rms", lambda *_: (np.array([0.01, 0.02]),
                                                  np.array([False, False])))


def _wind_tracking(mp, module):
    calls = []
    mp.setattr(module, "evaluate", lambda *_, **options: calls.append(options) or [])
    module.evaluate_calls = calls


def _tunnel_rows(seeds, statistics=()):
    from quad_dob_training.wind_tunnel.published import COUNTERPARTS, WIND_SPEEDS
    return [{"policy": policy, "scenario": f"figure8-wind-{speed}", "wind_speed": float(speed),
             "crashes": 0, "scored_seeds": seeds, "rms_after_skip": [0.01] * len(seeds),
             "laps": 5, "mean": {"5": {"z_share": 0.1}},
             "per_seed": {"5": [dict.fromkeys(statistics, 0.01) for _ in seeds]}}
            for policy in COUNTERPARTS for speed in WIND_SPEEDS]


def _wind_tunnel_ablation(mp, module):
    calls = []
    statistics = getattr(module, "STATISTICS", {})

    def simulate(benchmark, seeds, *_, progress=False):
        calls.append(progress)
        return _tunnel_rows(seeds, statistics)

    mp.setattr(module, "simulate", simulate)
    module.simulate_calls = calls


# script -> (stubs, arguments, its first line's start, lines its standard error holds in
# that order: one per unit, the last one's count the total)
CASES = {
    "gain_set_delay_margins": (
        _gain_set_delay_margins, ["--controllers", "pid,smc"],
        "gain_set_delay_margins: 2 gain sets x 5 tuning scenarios",
        ["gain_set_delay_margins 1/10 pid, dryden-helix-gusts: 20 ms",
         "gain_set_delay_margins 6/10 smc, dryden-helix-gusts: 20 ms",
         "gain_set_delay_margins 10/10 smc, helix-force-torque-perturbed: 20 ms"]),
    "gate_under_noise": (
        _gate_under_noise, [], "gate_under_noise: residual on paper-none",
        ["loading 1/1 residual: residual:v1", "gate_under_noise 1/3 ideal: gate open 50.0%",
         "gate_under_noise 2/3 mocap", "gate_under_noise 3/3 gnss-imu"]),
    "l2f_speed": (
        _l2f_speed, ["--sizes", "1,2", "--repeats", "2"],
        "l2f_speed: L2F (OMP_NUM_THREADS 1, 2) and ours (ours v4, ours like) at 2 batch sizes",
        ["l2f_speed 1/6 N = 1: building and warming", "l2f_speed 2/6 N = 1, repeat 1/2",
         "l2f_speed 4/6 N = 2: building and warming", "l2f_speed 6/6 N = 2, repeat 2/2"]),
    "landings_under_margin": (
        _landings_under_margin, ["--policies", "pid,smc", "--scenarios", "a,b", "--seeds",
                                 "1-3"],
        "landings_under_margin: 2 policies x 2 scenarios x 3 seeds",
        ["loading policies 1/2 pid", "loading policies 2/2 smc",
         "landings_under_margin 1/4 a, pid: 0 of 3 lost", "landings_under_margin 2/4 a, smc",
         "landings_under_margin 3/4 b, pid", "landings_under_margin 4/4 b, smc"]),
    "render_speed": (
        _render_speed, [], "render_speed: geometric-ndob:tuned through paper-II",
        ["render_speed 1/5 episode second 1: 100 frames",
         "render_speed 3/5 episode second 3: 250 frames", "render_speed 4/5 encoding the video",
         "render_speed 5/5 50 frames drawn"]),
    "residual_in_its_loop": (
        _residual_in_its_loop, ["runs/a", "runs/b"],
        "residual_in_its_loop: 2 runs x (policy, base)",
        ["loading runs 2/2 runs/b", "residual_in_its_loop 1/4 a, policy: 10.0 mm",
         "residual_in_its_loop 2/4 a, base", "residual_in_its_loop 4/4 b, base"]),
    "residual_room": (
        _residual_room, ["--scenarios", "a,b", "--lead", "0.02", "--specific-force", "1/10"],
        "residual_room: 2 scenarios x (the base, 1 leads, 1 specific-force filters)",
        ["residual_room 1/6 a, base: 10.0 mm", "residual_room 2/6 a, lead 0.02 s",
         "residual_room 3/6 a, specific-force k 1 fc 10 Hz", "residual_room 6/6 b"]),
    "residual_vs_strongest": (
        _residual_vs_strongest, ["--residuals", "residual:x", "--scenarios", "a,b",
                                 "--seeds", "1-3"],
        "residual_vs_strongest: 7 policies (6 classical, 1 learned) x 2 scenarios x 3 seeds",
        ["loading 1/1 residual:x, to find its base: geometric-ndob:tuned",
         "residual_vs_strongest: scenario 1/2 a", "residual_vs_strongest: scenario 2/2 b"]),
    "side_by_side": (
        _side_by_side, ["--commits", "old", "--cases", "v1", "--repeats", "2", "--workdir",
                        "{tmp}"],
        "side_by_side: 1 cases x 2 versions x 2 interleaved repeats",
        ["side_by_side install 1/1 old", "side_by_side v1 1/6 compiling working tree",
         "side_by_side v1 2/6 compiling old",
         "side_by_side v1 3/6 repeat 1/2, working tree: 100.0k steps/s",
         "side_by_side v1 6/6 repeat 2/2, old"]),
    "side_by_side --pair": (
        _side_by_side, ["--pair", "v4,v3", "--repeats", "2", "--workdir", "{tmp}"],
        "side_by_side: v4 and v3 on the working tree, 2 interleaved repeats",
        ["side_by_side 1/6 compiling v4", "side_by_side 2/6 compiling v3",
         "side_by_side 6/6 repeat 2/2, v3"]),
    "side_by_side, a version that cannot fly the case": (
        _side_by_side_one_cannot_fly, ["--commits", "old", "--cases", "v1", "--repeats", "2",
                                       "--workdir", "{tmp}"],
        "side_by_side: 1 cases x 2 versions",
        ["side_by_side v1 2/4 compiling old: cannot fly it",
         "side_by_side v1 4/4 repeat 2/2, working tree"]),
    "soak": (
        _soak, ["--steps", "400", "--num-envs", "4"],
        "soak: 400 vehicle-steps (4 vehicles x 100 steps)",
        ["soak 1/11 warm-up", "soak 2/11 steps 1-10: 0 episodes ended so far",
         "soak 11/11 steps 91-100"]),
    "supervisor_signals": (
        _supervisor_signals, ["--scenarios", "a,b"],
        "supervisor_signals: geometric-ndob:tuned alone on 2 scenarios x (nominal, margin)",
        ["supervisor_signals 1/4 a, nominal: 0 lost", "supervisor_signals 2/4 a, margin",
         "supervisor_signals 4/4 b, margin"]),
    "throughput": (
        _throughput, ["--batch-sizes", "1", "--vector-sizes", "1", "2", "--sensing-repeats",
                      "2"],
        "throughput: single env, batched core, vector env",
        ["throughput single env and core 1/2 single env, calm and windy",
         "throughput single env and core 2/2 batched core N = 1",
         "throughput vector env 2/2 N = 2", "throughput sensing 9/9 repeat 2/2 of 7 variants",
         "throughput loop 15/15 repeat 2/2 of 13 loops", "throughput memory 2/2 base in the loop"]),
    "training_speed": (
        _training_speed, ["--timesteps", "1000"],
        "training_speed: PPO on QuadDOB/TracksResidual-v2, one iteration of warm-up, then "
        "1,000 timesteps timed (2 iterations of 500)",
        ["training_speed 1/4 building the model", "training_speed 2/4 warm-up iteration",
         "training_speed 3/4 iteration 1 (500 timesteps)",
         "training_speed 4/4 iteration 2 (500 timesteps)"]),
    "transfer_bases": (
        _transfer_bases, ["--residuals", "residual:a,residual:b", "--scenarios", "s,t",
                          "--seeds", "1-2"],
        "transfer_bases: 2 residuals and their bases x 2 scenarios x 2 seeds",
        ["loading residuals 2/2 residual:b", "transfer_bases 1/8 s, residual:a: 15.0 mm",
         "transfer_bases 2/8 s, pid at v2 gains",
         "transfer_bases 8/8 t, pid at v2 gains"]),
    "wind_tracking": (
        _wind_tracking, [], "wind_tracking: 5 controllers x 7 scenarios x 20 seeds", []),
    "wind_tunnel_ablation_v3": (
        _wind_tunnel_ablation, ["--variants", "Benchmark v3,gyro low-pass off", "--seeds",
                                "1-2"],
        "wind_tunnel_ablation_v3: 2 variants x 4 controllers x 4 winds x 2 seeds",
        ["wind_tunnel_ablation_v3: variant 1/2 Benchmark v3",
         "wind_tunnel_ablation_v3: variant 2/2 gyro low-pass off"]),
    "wind_tunnel_ablation_v4": (
        _wind_tunnel_ablation, ["--variants", "drag v3's", "--seeds", "1-2"],
        "wind_tunnel_ablation_v4: 2 variants x 4 controllers x 4 winds x 2 seeds",
        ["wind_tunnel_ablation_v4: variant 1/2 Benchmark v4",
         "wind_tunnel_ablation_v4: variant 2/2 drag v3's"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_long_script_says_what_it_will_do_then_reports_each_unit(monkeypatch, capsys,
                                                                   tmp_path, case,
                                                                   benchmark_script):
    stubs, argv, first, expected = CASES[case]
    name = case.split()[0].rstrip(",")
    module = benchmark_script(name)
    stubs(monkeypatch, module)
    monkeypatch.setattr(sys, "argv", [name, *(arg.replace("{tmp}", str(tmp_path))
                                              for arg in argv)])
    module.main()
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert lines and lines[0].startswith(first), lines[:3]
    # each expected line, in order, with the time so far after it
    at = 0
    for wanted in expected:
        found = next((k for k in range(at, len(lines)) if lines[k].startswith(wanted)), None)
        assert found is not None, f"{wanted!r} not on standard error after line {at}:\n" + \
            captured.err
        if not re.match(r"\S+: ", wanted):  # a unit's line (no heading) ends with its time
            assert re.search(r"\(\d+ s in\)$", lines[found]), lines[found]
        at = found + 1
    # one line per unit, counted 1, 2, ... up to the total
    counts: dict[str, list[tuple[int, int]]] = {}
    for line in lines:
        match = re.match(r"(.*?) (\d+)/(\d+)[ :].*\(\d+ s in\)$", line)
        if match and ": still on " not in line:
            counts.setdefault(match[1], []).append((int(match[2]), int(match[3])))
    for label, done in counts.items():
        assert [k for k, _ in done] == list(range(1, len(done) + 1)), (label, done)
        assert done[-1][0] == done[-1][1], (label, done)
    # what the script prints as its result stays on standard output
    assert not any(line.startswith("|") for line in lines)
    calls = getattr(module, "evaluate_calls", None) or getattr(module, "simulate_calls", None)
    if calls is not None:  # evaluate and simulate report the units themselves
        assert calls and all(call is True or (isinstance(call, dict) and call["progress"])
                             for call in calls)


def test_supervisor_signals_table_fits_120_columns(monkeypatch, capsys, benchmark_script):
    module = benchmark_script("supervisor_signals")
    _supervisor_signals(monkeypatch, module)
    monkeypatch.setattr(sys, "argv", ["supervisor_signals"])  # every scenario
    module.main()
    out = capsys.readouterr().out.splitlines()
    table = [line for line in out if line.startswith(("scenario", "hover-calm", "random"))]
    assert table and max(len(line) for line in out[2:]) <= 120, "\n".join(out)


def _reports_progress(source: str) -> bool:
    """Through ``quad_dob_training.progress``, or ``evaluate``'s or ``simulate``'s own."""
    return "quad_dob_training.progress" in source or "progress=True" in source


def test_every_benchmark_script_reports_progress_or_was_measured_under_10_s():
    scripts = sorted(path.stem for path in BENCHMARKS.glob("*.py"))
    assert len(scripts) >= 20
    silent = [name for name in scripts
              if not _reports_progress((BENCHMARKS / f"{name}.py").read_text())]
    # a script over 10 s reports progress; one without must be measured and listed here
    assert sorted(silent) == sorted(UNDER_10_S), (
        "give these scripts progress (quad_dob_training.progress), or measure them under "
        f"10 s and list them in UNDER_10_S: {sorted(set(silent) - set(UNDER_10_S))}; "
        f"listed but reporting or gone: {sorted(set(UNDER_10_S) - set(silent))}")
    # and every script that reports has its output captured above
    tested = {case.split()[0].rstrip(",") for case in CASES}
    assert tested == set(scripts) - set(UNDER_10_S)
