import subprocess
import sys

import pytest

from quad_dob_training.cli.commands import main


def test_list_names_ids_and_scenarios(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "QuadDOB/Track-v1" in out and "ground-effect-landing" in out
    assert "QuadDOB/TrackResidual-v2" in out and "benchmark v2" in out
    # every scenario's feasibility margins, the controllers and the wind presets
    assert out.count("margins thrust") == out.count("actuation; margins") >= 11
    assert "rotors +22%" in out  # the wind helix: its tightest axis
    assert ("Controllers: geometric, geometric-ndob, geometric-ndob:tuned, "
            "geometric-ndob:gains-tuned, geometric-integral, indi, indi-outer, l1, l1-matched, "
            "nf-constant, nf-baseline, pid, smc") in out
    assert "moderate" in out and "Policies:" in out
    assert "torque_coefficient" in out and "APC 10x4.7" in out  # vehicle numbers, sourced


@pytest.mark.slow
def test_console_script_rejects_an_unknown_command():
    result = subprocess.run([sys.executable, "-m", "quad_dob_training.cli", "fly"],
                            capture_output=True,
                            text=True)
    assert result.returncode == 2 and "invalid choice: 'fly'" in result.stderr


def test_every_tool_flies_v4_unless_told(monkeypatch, tmp_path):
    """evaluate (and --suite), tune and check-controller fly the newest benchmark when no
    --benchmark is given, and the one given when it is; the leaderboard lays rows out by
    v4's suite."""
    import inspect

    import quad_dob_composition.checks as checks
    import quad_dob_training.evaluation.evaluate as evaluate
    import quad_dob_training.tuning.tune as tune

    seen: list[tuple[str, str]] = []
    monkeypatch.setattr(evaluate, "main", lambda *a, scenario_options, **k: seen.append(
        ("evaluate", scenario_options["benchmark"])) or 0)
    monkeypatch.setattr(tune, "main", lambda controllers, out, benchmark, *a, **k: seen.append(
        ("tune", benchmark)) or 0)
    monkeypatch.setattr(checks, "check_controller", lambda name, vehicle, benchmark: seen.append(
        ("check-controller", benchmark)) or [])
    out = str(tmp_path / "out")
    for flags in ([], ["--benchmark", "v2"]):
        assert main(["evaluate", "--out", out, *flags]) == 0
        assert main(["evaluate", "--suite", "--out", out, *flags]) == 0
        assert main(["tune", "--out", out, *flags]) == 0
        assert main(["check-controller", "pid", *flags]) == 0
    assert seen == [(tool, benchmark) for benchmark in ("v4", "v2") for tool in
                    ("evaluate", "evaluate", "tune", "check-controller")]
    assert inspect.signature(evaluate.leaderboard).parameters["benchmark"].default == "v4"
    assert evaluate.SUITES["v3"] == evaluate.SUITES["v2"]


def test_an_unknown_shipped_name_is_told_the_shipped_ones(capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", "residual:v9", "--seeds", "1"])
    error = capsys.readouterr().err
    assert "'residual:v9' names no shipped policy (residual:v1, residual:v2, residual:v3" in error
    assert "no file or run folder 'v9'" in error


def test_a_negative_seed_range_gets_the_seeds_message_not_argparses(capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--seeds", "-5-3", "--policies", "pid"])
    error = capsys.readouterr().err
    assert "expected one argument" not in error
    assert "seeds must be a count >= 1 such as 20 or an inclusive range A-B" in error
    assert "got '-5-3'" in error
