"""benchmarks/l2f_speed.py (issue 58): without l2f it says so in one line and exits 0; our two
loops are the ones docs/speed.md names; L2F's driver resets the vehicles done and keeps the
time limit; the tables fit 120 columns. L2F itself is faked here (it is no dependency), and
no assertion rests on a clock."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from quad_dob_env import ALL_ENV_IDS
from quad_dob_env.scenarios import make_scenario

SCRIPT = Path(__file__).parents[1] / "benchmarks" / "l2f_speed.py"


@pytest.fixture
def script(benchmark_script, monkeypatch):
    """The script as a module; the folder it puts on ``sys.path`` taken off again after."""
    monkeypatch.setattr(sys, "path", list(sys.path))
    return benchmark_script("l2f_speed")


def test_without_l2f_it_prints_one_line_and_exits_0(tmp_path):
    # an l2f that cannot be imported, ahead of any installed one
    (tmp_path / "l2f.py").write_text("raise ImportError('hidden by the test')\n")
    result = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True,
                            env={**os.environ, "PYTHONPATH": str(tmp_path)}, timeout=300)
    assert result.returncode == 0, result.stderr
    lines = (result.stdout + result.stderr).splitlines()
    assert len(lines) == 1, lines
    assert "l2f is not importable (hidden by the test)" in lines[0]
    assert "pip install" in lines[0] and "PYTHONPATH=" in lines[0]


def test_without_l2f_nothing_is_built(script, monkeypatch, capsys):
    def built(*_, **__):
        raise AssertionError("built something without l2f")

    monkeypatch.setattr(script, "load_l2f", lambda: "No module named 'l2f'")
    for name in ("warm_up", "our_env", "L2FChild", "hold_to_cores"):
        monkeypatch.setattr(script, name, built)
    monkeypatch.setattr(sys, "argv", ["l2f_speed"])
    script.main()
    captured = capsys.readouterr()
    assert captured.out.splitlines() == [script.MISSING.format(error="No module named 'l2f'")]
    assert captured.err == ""


def test_ours_are_v4s_full_loop_and_it_with_sensing_and_the_inner_loop_off(script,
                                                                         monkeypatch):
    made = []
    monkeypatch.setattr(script.gym, "make_vec", lambda env_id, **kw: made.append((env_id, kw)))
    for options in script.OURS.values():
        script.our_env(3, options)
    assert [env_id for env_id, _ in made] == ["QuadDOB/TrackResidual-v4"] * 2
    assert [kw["num_envs"] for _, kw in made] == [3, 3]
    full, like = (make_scenario(ALL_ENV_IDS[script.OUR_ID], benchmark="v4",
                                **(kw["scenario_options"] or {})) for _, kw in made)
    # one control step of 10 ms on both; the full loop flies it as two ticks of 200 Hz
    assert full.dt == like.dt == 0.01
    assert (full.inner_ticks, like.inner_ticks) == (2, 1)
    assert full.loop.sensing.name == "mocap" and like.loop.sensing is None  # None: ideal
    # the rest of v4's loop stays in both: the rotors' speed and its lag, their aerodynamics,
    # the drag in the wind
    for loop in (full.loop, like.loop):
        assert loop.speed_motors and loop.rotor_aerodynamics and loop.drag
        assert loop.motor_time_constants == full.loop.motor_time_constants


class _FakeVector:
    """One of L2F's vector modules, its calls recorded: vehicle 1 crashes at every step."""

    def __init__(self, n: int, limit: int) -> None:
        self.n, self.calls, self.resets = n, [], []
        self.VectorEnvironment = lambda: SimpleNamespace(ACTION_DIM=4, OBSERVATION_DIM=82,
                                                         EPISODE_STEP_LIMIT=limit)
        self.VectorRng = self.VectorParameters = self.VectorState = object

    def initialize_rng(self, *_):
        pass

    initialize_environment = sample_initial_parameters = sample_initial_state = initialize_rng

    def step(self, device, env, parameters, state, actions, next_state, rng):
        self.calls.append(("step", state, next_state, actions[0, 0]))
        return [np.float32(0.01)] * self.n

    def reward(self, *arguments):
        arguments[-2][:] = 1.0

    def terminated(self, device, env, parameters, state, flags, rng):
        self.calls.append(("terminated", state))
        flags[:] = np.arange(self.n) == 1

    def sample_initial_parameters_if_truncated(self, device, env, parameters, done, rng):
        self.calls.append(("parameters", done.copy()))

    def sample_initial_state_if_truncated(self, device, env, parameters, state, done, rng):
        self.resets.append(done.copy())

    def observe(self, device, env, parameters, state, observation, rng):
        self.calls.append(("observe", state))


def test_l2f_rl_step_resets_the_vehicles_done_and_keeps_the_time_limit(script):
    vector = _FakeVector(3, limit=2)
    l2f = SimpleNamespace(vector_selector={3: vector}, Device=object)
    env = script.L2FVector(l2f, 3, action=0.25)
    first, second = env.state, env.next_state
    env.rl_step()
    env.rl_step()
    # vehicle 1 ends each step; vehicles 0 and 2 reach the 2-step limit at the second
    assert [done.tolist() for done in vector.resets] == [[False, True, False], [True] * 3]
    assert env.resets == 4 and env.episode_step.tolist() == [0, 0, 0]
    # each step reads one state and writes the other, then they swap: no copy
    steps = [call for call in vector.calls if call[0] == "step"]
    assert [(call[1], call[2]) for call in steps] == [(first, second), (second, first)]
    # termination and the observation read the state after the step
    assert [call[1] for call in vector.calls if call[0] in ("terminated", "observe")] == [
        second, second, first, first]
    assert steps[0][3] == np.float32(0.25) and env.dt == pytest.approx(0.01)


def test_l2f_step_alone_calls_only_the_step(script):
    vector = _FakeVector(2, limit=500)
    env = script.L2FVector(SimpleNamespace(vector_selector={2: vector}, Device=object), 2, 0.0)
    for _ in range(5):
        env.step()
    assert [call[0] for call in vector.calls] == ["step"] * 5 and not vector.resets


def test_a_measurement_of_l2f_stops_at_its_time_but_takes_a_step(script):
    vector = _FakeVector(2, limit=500)
    env = script.L2FVector(SimpleNamespace(vector_selector={2: vector}, Device=object), 2, 0.0)
    env.rate("RL", 1000, seconds=0.0)
    assert env.steps == 1
    env.rate("step", 3)
    assert env.steps == 4


def test_the_hover_action_carries_the_weight(script):
    dynamics = {"rotor_thrust_coefficients": [[0.0035, 0.0144, 0.0922]] * 4,
                "rotor_positions": [[0.0, 0.0, 0.0]] * 4, "mass": 0.0306,
                "gravity": [0.0, 0.0, -9.81], "action_limit": {"min": 0.0, "max": 1.0}}
    l2f = SimpleNamespace(Device=object, Environment=object, Parameters=object,
                          initialize_environment=lambda *_: None,
                          initial_parameters=lambda *_: None,
                          parameters_to_json=lambda *_: json.dumps({"dynamics": dynamics}))
    action = script.hover_action(l2f)
    speed = (action + 1) / 2  # the action's [-1, 1] onto the rotors' [0, 1]
    c0, c1, c2 = dynamics["rotor_thrust_coefficients"][0]
    assert 4 * (c0 + c1 * speed + c2 * speed**2) == pytest.approx(0.0306 * 9.81)


def test_steps_per_measurement_stay_within_bounds(script):
    assert script.steps_for(1, 120_000) == 2000
    assert script.steps_for(1024, 120_000) == 117
    assert script.steps_for(8192, 120_000) == 20


def test_a_ratio_is_paired_by_repeat(script):
    assert script.ratio([10.0, 20.0, 30.0], [1.0, 4.0, 2.0]) == "10 [5, 15]"
    assert script.ratio([1.0], [40.0]) == "0.025 [0.025, 0.025]"


class _FakeChild:
    def __init__(self, threads: int) -> None:
        self.threads = threads

    def measure(self, n, mode, steps, seconds=None):
        return {"rate": 4e6 * self.threads, "dt": 0.01, "steps": steps, "reset_share": 0.02}

    def close(self):
        pass


def stub_l2f_speed(monkeypatch, module) -> None:
    """The script's work stubbed: L2F at 4 M env-steps/s a thread, ours at 100,000."""
    monkeypatch.setattr(module, "load_l2f", lambda: SimpleNamespace(
        vector_selector=dict.fromkeys([1, 2, 4, 8192]), __file__="/site/l2f/__init__.py"))
    monkeypatch.setattr(module, "hold_to_cores", lambda cores: cores)
    monkeypatch.setattr(module, "warm_up", lambda: None)
    monkeypatch.setattr(module, "L2FChild", _FakeChild)
    monkeypatch.setattr(module, "our_env", lambda n, options: None)
    monkeypatch.setattr(module, "compiled_and_warm", lambda env: None)
    monkeypatch.setattr(module, "flown", lambda env: (0.01, True))
    monkeypatch.setattr(module, "timed_env_steps_per_second", lambda *_: 1e5)


def test_the_tables_fit_120_columns_and_state_the_ratio(script, monkeypatch, capsys):
    stub_l2f_speed(monkeypatch, script)
    monkeypatch.setattr(sys, "argv", ["l2f_speed", "--sizes", "1,8192", "--repeats", "2"])
    script.main()
    out = capsys.readouterr().out.splitlines()
    table = [line for line in out if line.startswith("|")]
    # the rates, then the ratios with L2F on one thread and on two
    assert len(table) == 3 * (2 + 2) and max(len(line) for line in table) <= 120
    assert "| 8192 | 4,000,000 | 8,000,000 | 4,000,000 | 8,000,000 | 100,000 | 100,000 |" in out
    one, two = (out.index(line) for line in out if line.startswith("L2F / ours"))
    assert "L2F on 1 thread," in out[one] and "L2F on 2 threads" in out[two]
    assert out[one + 5] == "| 8192 | " + " | ".join(["40 [40, 40]"] * 4) + " |"
    assert out[two + 5] == "| 8192 | " + " | ".join(["80 [80, 80]"] * 4) + " |"


def test_sizes_must_be_among_l2fs_compiled_ones(script, monkeypatch):
    stub_l2f_speed(monkeypatch, script)
    monkeypatch.setattr(sys, "argv", ["l2f_speed", "--sizes", "3"])
    with pytest.raises(SystemExit):
        script.main()
