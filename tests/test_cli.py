import subprocess
import sys

from training.cli import main


def test_list_names_ids_and_scenarios(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "QuadDOB/Track-v0" in out and "ground-effect-landing" in out


def test_console_script_rejects_an_unknown_command():
    result = subprocess.run([sys.executable, "-m", "training.cli", "fly"], capture_output=True,
                            text=True)
    assert result.returncode == 2 and "invalid choice: 'fly'" in result.stderr
