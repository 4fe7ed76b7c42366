"""Every file and value the command line is given is checked before any work starts, and a
failure is ``quad-dob: error: ...`` with status 2, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from quad_dob_training.cli.commands import main

READ_ONLY = Path("/sys/kernel")  # sysfs: not writable, even by root (CI runs as root)


def _error(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


def test_an_output_folder_that_is_a_file_is_refused_before_anything_runs(tmp_path, capsys):
    existing = tmp_path / "taken"
    existing.write_text("")
    for command in (["evaluate", "--policies", "geometric"], ["paper"], ["tune"],
                    ["train"]):
        err = _error([*command, "--out", str(existing)], capsys)
        assert f"quad-dob: error: --out '{existing}' is a file, not a folder" in err
    err = _error(["sweep", str(tmp_path / "nowhere.yaml")], capsys)
    assert "quad-dob: error: sweep config" in err and "is not a file" in err


@pytest.mark.skipif(not READ_ONLY.is_dir(), reason="needs sysfs")
@pytest.mark.parametrize("out", [READ_ONLY, READ_ONLY / "results"])
def test_a_read_only_output_folder_is_refused_before_anything_runs(out, capsys):
    err = _error(["evaluate", "--policies", "geometric", "--out", str(out)], capsys)
    assert f"quad-dob: error: --out '{out}' cannot be written" in err


def test_a_video_path_that_is_a_folder_or_cannot_be_written_is_refused(tmp_path, capsys):
    err = _error(["replay", "--out", str(tmp_path)], capsys)
    assert "is a folder: give a file name" in err
    if READ_ONLY.is_dir():
        err = _error(["replay", "--out", str(READ_ONLY / "flight.gif")], capsys)
        assert "--out's folder '/sys/kernel' cannot be written" in err


@pytest.mark.parametrize(("argv", "message"), [
    (["train", "--timesteps", str(10**24)], "--timesteps: must be >= 1 and <= 1e+11"),
    (["train", "--timesteps", "lots"], "--timesteps: must be a whole number, got 'lots'"),
    (["train", "--seed", "-1"], "--seed: must be >= 0"),
    (["train", "--n-envs", str(10**9)], "1,000,000,000 vehicles would take 7.45 TiB, over "
                                         "the memory budget of 4 GiB: fly fewer vehicles at "
                                         "once (--n-envs)"),
    (["train", "--conf-file", "/nonexistent.yml"], "--conf-file '/nonexistent.yml' is not a"),
    (["paper", "--dt", "nan"], "--dt: must be > 0 and <= 1e+09, got nan"),
    (["replay", "--width", "100000000"], "--width: must be >= 16 and <= 4096"),
    (["replay", "--fps", "inf"], "--fps: must be > 0 and <= 1000, got inf"),
])
def test_absurd_values_are_refused_by_name(argv, message, capsys):
    assert message in _error(argv, capsys)


def test_scenario_options_are_parsed_by_the_cli_before_they_reach_the_library(capsys):
    from quad_dob_training.cli.checks import key_values

    assert key_values(["dt=0.005", "wind=moderate", "motor_lag=true", "wind_scale=2",
                        "duration=1e3", "reference_start_spread=2.5E-1"],
                       "--scenario-option") == {"dt": 0.005, "wind": "moderate",
                                                "motor_lag": True, "wind_scale": 2,
                                                "duration": 1000.0,
                                                "reference_start_spread": 0.25}
    for bad, message in (("dt", "takes KEY=VALUE"), ("=1", "takes KEY=VALUE"),
                         ("dt=[1", "the value is not")):
        err = _error(["evaluate", "--policies", "geometric", "--json",
                      "--scenario-option", bad], capsys)
        assert message in err
    err = _error(["evaluate", "--benchmark", "v1", "--policies", "geometric", "--json",
                  "--scenarios", "paper-none", "--seeds", "1", "--scenario-option",
                  "duration=lots"], capsys)
    assert "quad-dob: error: Scenario.duration must be a number, got str 'lots'" in err


def test_the_benchmark_given_as_a_scenario_option_alone_is_taken(capsys):
    import json

    assert main(["evaluate", "--policies", "geometric", "--baseline", "", "--json",
                 "--scenarios", "paper-none", "--seeds", "1", "--scenario-option",
                 "benchmark=v1", "--scenario-option", "duration=1.0"]) == 0
    row = json.loads(capsys.readouterr().out)[0]
    assert row["scenario"] == "paper-none" and row["gains"] == "defaults"


def test_a_scenario_option_changes_every_flight(capsys):
    import json

    assert main(["evaluate", "--benchmark", "v1", "--policies", "geometric", "--baseline", "",
                 "--json", "--scenarios", "paper-none", "--seeds", "1",
                 "--scenario-option", "duration=3.0"]) == 0
    plain = json.loads(capsys.readouterr().out)[0]
    assert main(["evaluate", "--benchmark", "v1", "--policies", "geometric", "--baseline", "",
                 "--json", "--scenarios", "paper-none", "--seeds", "1"]) == 0
    longer = json.loads(capsys.readouterr().out)[0]
    assert plain["rms_position_settled_mean"] != longer["rms_position_settled_mean"]


@pytest.mark.slow
def test_a_reader_that_stops_early_ends_the_command_quietly(capsys):
    """`quad-dob list | head -2`: the pipe closes mid-listing; no traceback, no error line."""
    import subprocess
    import sys

    assert main(["list"]) == 0
    # longer than Python's 8 KiB stdout buffer, so the writer meets the closed pipe
    assert len(capsys.readouterr().out) > 8192

    process = subprocess.Popen([sys.executable, "-m", "quad_dob_training.cli", "list"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = process.stdout.readline()
    process.stdout.close()  # what head does after its lines
    _, err = process.communicate(timeout=120)
    assert first.startswith(b"Environment ids")
    assert err == b"", err.decode()
    assert process.returncode == 1


def test_every_option_of_every_command_says_what_it_does_and_its_default():
    import argparse

    from quad_dob_training.cli.commands import build_parser

    subcommands = next(action for action in build_parser()._actions
                       if isinstance(action, argparse._SubParsersAction))
    for name, parser in subcommands.choices.items():
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction) or not action.option_strings:
                continue
            where = f"quad-dob {name} {action.option_strings[0]}"
            assert action.help, f"{where} has no help text"
            if action.default not in (None, False) or not action.required:
                flag = isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction))
                assert flag or "default" in action.help, f"{where} does not say its default"


@pytest.mark.slow
def test_a_sweep_sent_to_a_ray_cluster_that_is_not_there_says_what_to_do(tmp_path, capsys):
    """`--ray-address auto` with no cluster: one message naming the address and the three
    ways on, not Ray's ConnectionError with Ray's own flag in it."""
    root = Path(__file__).parents[1]
    err = _error(["sweep", str(root / "training/sweeps/observer_rate_vs_wind.yaml"),
                  "--ray-address", "auto", "--out", str(tmp_path / "sweep")], capsys)
    assert "quad-dob: error: --ray-address auto: no Ray cluster answers there" in err
    assert "ray start --head" in err and "--ray-address local" in err
    assert "--address" not in err.replace("--ray-address", "")


def test_the_hyperparameter_files_are_found_from_any_directory(tmp_path, monkeypatch, capsys):
    """rl-zoo3's --conf-file outside the checkout: `quad-dob hyperparams ALGO` prints the
    installed file, which is the one `quad-dob train` reads."""
    import yaml

    monkeypatch.chdir(tmp_path)
    for algo in ("ppo", "sac", "td3"):
        assert main(["hyperparams", algo]) == 0
        path = Path(capsys.readouterr().out.strip())
        assert path.is_absolute() and path.name == f"{algo}.yml"
        assert "QuadDOB/HoverResidual-v1" in yaml.safe_load(path.read_text())
    err = _error(["hyperparams", "ddpg"], capsys)
    assert "invalid choice: 'ddpg'" in err
