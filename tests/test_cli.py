import subprocess
import sys

from training.cli import main
from training.demo import DEMO_SCENARIOS, fly_open_loop


def test_demo_prints_a_row_per_scenario(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    for name in DEMO_SCENARIOS:
        assert f"| {name}" in out


def test_open_loop_hover_in_paper_ii_is_toppled_by_the_torque_disturbance():
    result = fly_open_loop("paper-II")
    assert result["ended_by"] == "attitude_lost" and result["flown_s"] < 2.0


def test_list_names_ids_and_scenarios(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "QuadDOB/Track-v0" in out and "ground-effect-landing" in out


def test_console_script_rejects_an_unknown_command():
    result = subprocess.run([sys.executable, "-m", "training.cli", "fly"], capture_output=True,
                            text=True)
    assert result.returncode == 2 and "invalid choice: 'fly'" in result.stderr
