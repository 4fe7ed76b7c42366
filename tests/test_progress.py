"""Progress on long work: the reporter itself, and each command's output captured with a
stub of its work (quad-dob paper, evaluate, tune, wind-tunnel and train)."""

from __future__ import annotations

import io
import re
import threading
import time

import pytest

from quad_dob_env import compile_notice
from quad_dob_training import cli, progress
from quad_dob_training.evaluation import console
from quad_dob_training.progress import Progress, compiling_notice, reported


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_gets_one_line_per_unit_and_a_heartbeat_while_one_runs_long():
    stream = io.StringIO()
    with Progress("job", 2, stream=stream, heartbeat=0.1) as report:
        report.start("first")
        report.done("3 flights")
        report.start("second")
        time.sleep(0.4)  # silent for longer than the heartbeat
        report.done()
    lines = stream.getvalue().splitlines()
    assert re.fullmatch(r"job 1/2 first: 3 flights \(\d+ s in\)", lines[0])
    assert any(re.fullmatch(r"job 1/2: still on second \(\d+ s in\)", line) for line in lines)
    assert re.fullmatch(r"job 2/2 second \(\d+ s in\)", lines[-1])
    # a unit that is done is not named by the heartbeat, and more units grow the total
    with Progress("job", 1, stream=stream, heartbeat=0.1) as report:
        report.start("first")
        report.done()
        report.done()
        time.sleep(0.3)
    tail = stream.getvalue().splitlines()
    assert any(line.startswith("job 2/2") for line in tail)
    assert not any("still on first" in line for line in tail)
    assert "\r" not in stream.getvalue()


def test_a_terminal_gets_one_bar_redrawn_in_place_and_ended_with_a_newline():
    stream = Terminal()
    with Progress("job", 4, stream=stream) as report:
        report.start("a")
        report.done()
        report.print("a result line", file=stream)
    text = stream.getvalue()
    assert text.count("\n") == 2  # the result line and the bar's end
    assert "\rjob [#####...............] 1/4 a" in text
    assert "a result line\n" in text
    assert "1/4 done" in text.splitlines()[-1]  # closed: the bar's last state, then a newline


def test_quiet_reports_nothing_and_reported_reports_each_item():
    silent = io.StringIO()
    with Progress("job", 1, stream=silent, quiet=True) as report:
        report.start("x")
        report.done()
    assert silent.getvalue() == ""
    stream = io.StringIO()
    assert list(reported(["a", "b"], "walk", stream=stream)) == ["a", "b"]
    assert [line.split(" (")[0] for line in stream.getvalue().splitlines()] == [
        "walk 1/2 a", "walk 2/2 b"]


def test_the_compile_notice_speaks_only_when_the_warm_up_is_slow(monkeypatch):
    monkeypatch.setattr(compile_notice, "COMPILE_MESSAGE_SAID", threading.Event())
    quick = io.StringIO()
    with compiling_notice(quick, after=0.5):
        pass
    assert quick.getvalue() == ""
    slow = io.StringIO()
    with compiling_notice(slow, after=0.05):
        time.sleep(0.3)
    lines = slow.getvalue().splitlines()
    assert lines[0] == progress.COMPILE_MESSAGE and "1-2 min" in lines[0]
    assert re.fullmatch(r"compiled in \d+ s", lines[1])


def test_the_simulators_entry_points_announce_a_slow_first_call_once(monkeypatch, capsys):
    """rl-zoo3 or a user's script drives the envs directly: the first reset and step in a
    process give the notice themselves, and a call inside another gives none of its own."""
    monkeypatch.setattr(compile_notice, "COMPILE_MESSAGE_SAID", threading.Event())
    monkeypatch.setattr(compile_notice, "COMPILE_NOTICE_AFTER", 0.05)

    class Simulator:
        @compile_notice.announces_compiling
        def inner(self) -> str:
            time.sleep(0.2)
            return "inner"

        @compile_notice.announces_compiling
        def step(self) -> str:
            return self.inner()

    simulator = Simulator()
    assert simulator.step() == "inner"
    first = capsys.readouterr().err.splitlines()
    assert first[0] == compile_notice.COMPILE_MESSAGE
    assert re.fullmatch(r"compiled in \d+ s", first[1]) and len(first) == 2
    assert simulator.step() == "inner" and simulator.inner() == "inner"
    assert capsys.readouterr().err == ""  # later calls: no timer, no line
    # and no wrapper: the class holds the plain methods again, the step pays nothing
    for name in ("step", "inner"):
        plain = Simulator.__dict__[name]
        assert not isinstance(plain, compile_notice.announces_compiling)
        assert not hasattr(plain, "__wrapped__")  # the method itself, no wrapper around it
        assert getattr(simulator, name).__func__ is plain
    # a long compilation is not silent: a line every COMPILE_HEARTBEAT seconds
    monkeypatch.setattr(compile_notice, "COMPILE_HEARTBEAT", 0.05)
    with compile_notice.compiling_notice():
        time.sleep(0.3)
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "compiling more of the simulator's kernels"
    assert any(re.fullmatch(r"still compiling \(\d+ s\)", line) for line in lines)
    assert lines[-1].startswith("compiled in")


def test_a_console_table_fits_120_columns_and_keeps_the_names_whole():
    header = ["scenario", "policy", *(f"a long score name number {k} [unit]" for k in range(6))]
    rows = [["figure8-wind-12.1", "geometric-ndob:tuned", *("12.3 ± 0.4",) * 6]]
    table = console.text_table(header, rows)
    assert max(len(line) for line in table.splitlines()) <= console.WIDTH
    assert "figure8-wind-12.1  geometric-ndob:tuned" in table  # the headers wrapped instead
    assert table.count("[unit]") == 6  # every header, whole
    # a name past NAME_WIDTH is cut, with an ellipsis
    long = console.text_table(["scenario", "policy", "x"], [["s", "p" * 40, "1"]])
    assert "p" * (console.NAME_WIDTH - 1) + "…" in long
    # too wide even with the names cut (a long text cell beyond them): it is cut as well
    wide = console.text_table(["policy", "source", "seeds", "across sources"],
                              [["pid", "alice", "0-2", "agrees with " + "bob, " * 40]], names=2)
    assert max(len(line) for line in wide.splitlines()) <= console.WIDTH
    assert "agrees with bob" in wide and "…" in wide
    # the demo's rows (a long scenario and policy, wide spreads) fit whole
    base = {"scenario": "dryden-helix-gusts", "crashes": 0, "flights": 20}
    values = {"rms_position_settled": (0.13333, 0.1272, 0.1394), "rms_moment": (5.335, 5.2, 5.4),
              "rms_command_rate": (2648.0, 2092.0, 3204.0)}
    rows = [{**base, "policy": name, "policy_spec": name,
             **{f"{key}_{part}": value for key, triple in values.items()
                for part, value in zip(("mean", "low", "high"), triple, strict=True)},
             "rms_position_settled_diff_mean": 0.0868, "rms_position_settled_diff_low": 0.083,
             "rms_position_settled_diff_high": 0.0909}
            for name in ("geometric-ndob:tuned", "residual:v4")]
    table = console.evaluation_table(rows, "geometric-ndob:tuned")
    assert max(len(line) for line in table.splitlines()) <= console.WIDTH
    assert "dryden-helix-gusts  geometric-ndob:tuned" in table and "…" not in table
    assert "+187% [+83.0, +90.9]" in table
    # ± with the mean's decimals, never an exponent
    row = {"rate_mean": 1234.0, "rate_low": 1100.0, "rate_high": 1340.0}
    assert console.mean_text(row, "rate", 1.0, 0) == "1234 ± 120"
    # a 27 g vehicle's effort keeps three significant figures, not 0.000
    small = {"effort_mean": 1.234e-4, "effort_low": 1.1e-4, "effort_high": 1.3e-4}
    assert console.mean_text(small, "effort", 1.0, None) == "0.000123 ± 0.000010"
    assert console.mean_text(row, "rate", 1.0, None) == "1234 ± 120"


@pytest.fixture
def heartbeat(monkeypatch):
    """A heartbeat of 0.2 s, so a stub that sleeps 0.6 s shows one."""
    monkeypatch.setattr(progress, "HEARTBEAT", 0.2)


def _slowed(function, seconds: float = 0.6):
    def slowed(*args, **kwargs):
        time.sleep(seconds)
        return function(*args, **kwargs)
    return slowed


def test_evaluate_says_what_it_flies_then_each_unit_and_prints_a_table_that_fits(
        tmp_path, capsys, monkeypatch, heartbeat):
    from quad_dob_training.evaluation import evaluate

    monkeypatch.setattr(evaluate, "fly_policy", _slowed(evaluate.fly_policy))
    assert cli.main(["evaluate", "--policies", "geometric-ndob:tuned,pid", "--scenarios",
                     "hover-calm", "--seeds", "2", "--scenario-option", "duration=2.5",
                     "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert lines[0] == ("evaluate: 2 policies x 1 scenarios x 2 seeds, Benchmark v4, into "
                        f"{tmp_path}")
    assert lines[1] == "evaluate: loading 2 policies"
    assert any(line.startswith("evaluate 1/2 hover-calm, geometric-ndob:tuned: 2 flights")
               for line in lines)
    assert any(line.startswith("evaluate 2/2 hover-calm, pid: 2 flights") for line in lines)
    assert any("still on hover-calm" in line for line in lines)
    assert max(len(line) for line in out.splitlines()) <= console.WIDTH
    words = " ".join(out.split())  # the legend is wrapped
    assert "± : half-width of the 95 % bootstrap interval" in words
    assert "Δ: paired change against geometric-ndob:tuned" in words


def test_paper_says_what_it_flies_then_each_controller_and_each_figure(
        tmp_path, capsys, monkeypatch):
    from quad_dob_training import paper

    built = paper.build_scenarios
    monkeypatch.setattr(paper, "build_scenarios", lambda *args: [
        scenario.with_changes(duration=2.5) for scenario in built(*args)])
    assert cli.main(["paper", "--scenarios", "paper-none,paper-I", "--controllers",
                     "geometric,pid", "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert err.splitlines()[0] == ("paper: 2 controllers x 2 scenarios, one flight each, "
                                   f"into {tmp_path}")
    for unit in ("paper 1/2", "paper 2/2", "paper figures 1/2", "paper figures 2/2"):
        assert unit in err
    assert {"geometric", "pid"} <= set(re.findall(r"paper \d/2 (\w+)", err))
    assert max(len(line) for line in out.splitlines()) <= console.WIDTH


def test_tune_says_what_it_tunes_then_each_trial(tmp_path, capsys, monkeypatch):
    from quad_dob_training.tuning import tune

    def scored(build, benchmark="v1", vehicle="paper", seeds=(), **options):
        build()
        return {"hover": 0.01, "objective": 0.01, "lost": 0, "shortfall": 0.0}

    monkeypatch.setattr(tune, "score", scored)
    assert cli.main(["tune", "--controllers", "pid", "--benchmark", "v1", "--passes", "1",
                     "--seeds", "2", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    # the start, then pid's seven gains at four factors in one pass: 29 trials
    assert tune.planned_trials("pid", "v1", "paper", 1) == 29
    assert err.splitlines()[0].startswith("tune: pid for Benchmark v1 on the paper vehicle")
    assert "tune pid 1/29 trial 1" in err and "tune pid 29/29 trial 29" in err


def test_wind_tunnel_says_what_it_flies_then_each_wind_and_controller(
        tmp_path, capsys, monkeypatch):
    from quad_dob_training.wind_tunnel import plots, tool

    record = {"crashes": 0}
    monkeypatch.setattr(tool, "_flown_in_tunnel", lambda spec, *args: {**record,
                                                                        "policy": spec})
    monkeypatch.setattr(tool, "fly_logs", lambda *args, **kwargs: [])
    monkeypatch.setattr(tool, "report", lambda *args: "the tables")
    monkeypatch.setattr(tool, "console_report", lambda *args: "the tables that fit")
    monkeypatch.setattr(tool, "compare_real", lambda *args: [])
    monkeypatch.setattr(plots, "write_figures", lambda *args: [])
    monkeypatch.setattr(tool, "_plain", lambda document: {})
    assert cli.main(["wind-tunnel", "--seeds", "2", "--out", str(tmp_path)]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("the tables that fit")
    assert (tmp_path / "wind_tunnel.md").read_text() == "the tables\n"
    pairs = tool.counterparts("v4")
    units = len(pairs) * len(tool.WIND_SPEEDS)
    assert err.splitlines()[0].startswith(f"wind-tunnel: {len(pairs)} controllers x "
                                          f"{len(tool.WIND_SPEEDS)} winds x 2 seeds")
    first = next(iter(pairs))
    assert f"wind-tunnel 1/{units} {first}, {tool.WIND_SPEEDS[0]} m/s: 0 of 2 lost" in err
    assert f"wind-tunnel {units}/{units} " in err


def test_train_off_a_terminal_prints_a_line_per_rollout_with_the_reward(tmp_path, capsys):
    assert cli.main(["train", "--env", "QuadDOB/HoverResidual-v3", "--timesteps", "2048",
                     "--n-envs", "4", "--evaluate-every", "100000", "--out",
                     str(tmp_path / "run")]) == 0
    captured = capsys.readouterr()
    assert captured.err.splitlines()[0].startswith("train: ppo on QuadDOB/HoverResidual-v3")
    lines = [line for line in captured.err.splitlines() if line.startswith("train ")]
    assert lines and re.match(r"train 1/\d+ [\d,]+ timesteps", lines[0])
    assert lines[-1].split()[1].split("/")[0] == lines[-1].split()[1].split("/")[1]


def test_a_training_that_fails_leaves_no_reporter_running(tmp_path, monkeypatch):
    from quad_dob_training.learning import train

    def fails(self):
        raise RuntimeError("a step failed")

    monkeypatch.setattr(train.BaselineEvaluation, "_on_step", fails)
    with pytest.raises(RuntimeError, match="a step failed"):
        cli.main(["train", "--env", "QuadDOB/HoverResidual-v3", "--timesteps", "512",
                  "--n-envs", "2", "--out", str(tmp_path / "run")])
    time.sleep(0.1)
    assert not [thread for thread in threading.enumerate()
                if thread.name.startswith("progress:") and thread.is_alive()]
