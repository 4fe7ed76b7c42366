import subprocess
import sys

from quad_dob_training.cli import main


def test_list_names_ids_and_scenarios(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "QuadDOB/Track-v1" in out and "ground-effect-landing" in out
    assert "QuadDOB/TrackResidual-v2" in out and "benchmark v2" in out
    # every scenario's feasibility margins, the controllers and the wind presets
    assert out.count("margins thrust") == out.count("actuation; margins") >= 11
    assert "rotors +22%" in out  # the wind helix: its tightest axis
    assert ("Controllers: geometric, geometric-ndob, geometric-ndob:tuned, "
            "geometric-ndob:gains-tuned, geometric-integral, indi, l1, pid, smc") in out
    assert "moderate" in out and "Policies:" in out
    assert "torque_coefficient" in out and "APC 10x4.7" in out  # vehicle numbers, sourced


def test_console_script_rejects_an_unknown_command():
    result = subprocess.run([sys.executable, "-m", "quad_dob_training.cli", "fly"],
                            capture_output=True,
                            text=True)
    assert result.returncode == 2 and "invalid choice: 'fly'" in result.stderr
