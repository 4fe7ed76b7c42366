"""The package as a user gets it: a wheel built from this checkout, installed outside it,
and one client of each kind run from there (rl-zoo3 train and enjoy, SB3 through the
adapter, ``quad-dob evaluate`` on the SB3 zip, ``quad-dob train``), in a folder that holds
no project file. The build prints no warning and writes nothing into the checkout."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CLIENTS = '''
import sys
from pathlib import Path

import quad_dob_env, quad_dob_training
for module in (quad_dob_env, quad_dob_training):
    assert Path(module.__file__).is_relative_to(Path(sys.argv[1])), module.__file__

# SB3 through the adapter, the model saved as SB3 saves it (no project config beside it)
from stable_baselines3 import PPO
from quad_dob_training.rl import make_sb3_vec_env
env = make_sb3_vec_env("QuadDOB/HoverResidual-v3", 4)
PPO("MlpPolicy", env, n_steps=32, batch_size=64, n_epochs=1, seed=0).learn(128).save("sb3")
assert Path("sb3.zip").is_file()

# quad-dob evaluate on that zip, the id supplying its base, options and benchmark
from quad_dob_training.cli import main
assert main(["evaluate", "--policies", "ppo:sb3.zip", "--env", "QuadDOB/HoverResidual-v3",
             "--scenarios", "gusty-hover", "--seeds", "2", "--baseline", "", "--out",
             "evaluation"]) == 0
assert Path("evaluation/evaluation.json").is_file()

# rl-zoo3 trains and enjoys from the hyperparameter file installed with the package
from quad_dob_training.rl import HYPERPARAMS
from rl_zoo3 import enjoy, train
common = ["--algo", "ppo", "--env", "QuadDOB/Hover-v3", "--gym-packages", "quad_dob_env",
          "-f", "logs", "--seed", "0"]
sys.argv = ["train", *common, "--conf-file", str(HYPERPARAMS / "ppo.yml"), "-n", "512",
            "--eval-freq", "-1", "-params", "n_envs:2", "n_steps:128", "batch_size:64",
            "n_epochs:1"]
train.train()
sys.argv = ["enjoy", *common, "-n", "50", "--no-render", "--exp-id", "1"]
enjoy.enjoy()
# quad-dob train, whose modules a wheel once left out
assert main(["train", "--env", "QuadDOB/HoverResidual-v3", "--timesteps", "256", "--n-envs",
             "2", "--out", "run", "--no-progress"]) == 0
assert Path("run/model.zip").is_file()
print("CLIENTS OK")
'''


# the folders pyproject.toml installs under other names
INSTALLED_AS = {"baselines": "quad_dob_baselines", "composition": "quad_dob_composition",
                "training": "quad_dob_training", "quad_dob_env": "quad_dob_env"}


def _tree_packages() -> set[str]:
    """Every folder of the repository Python imports as a package, by its installed name:
    those with an ``__init__.py`` and the data folders beside them (git's files: a run
    folder or a notebook checkpoint left in the working tree is not the package's)."""
    tracked = subprocess.run(["git", "ls-files", *INSTALLED_AS], cwd=ROOT, check=True,
                             capture_output=True, text=True).stdout.split()
    found = set(INSTALLED_AS.values())
    for path in map(Path, tracked):
        folder, *inside = path.parent.parts
        if folder in INSTALLED_AS:
            found.add(".".join([INSTALLED_AS[folder], *inside]))
    return found


def test_every_package_and_data_folder_of_the_tree_is_listed():
    """A folder left out of pyproject.toml's list is missing from the wheel:
    ``quad_dob_training.learning`` was, and ``quad-dob train`` failed from a wheel."""
    tomllib = pytest.importorskip("tomllib")  # Python 3.11's; CI runs 3.11
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    assert _tree_packages() - listed == set(), "folders pip install . would leave out"
    assert listed - _tree_packages() == set(), "listed packages with no folder"


@pytest.mark.slow
def test_each_client_runs_from_a_wheel_installed_outside_the_checkout(tmp_path):
    # built from a clone holding the working tree's packaging files: the build must write
    # nothing into it and print no warning
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True, timeout=120)
    for name in ("pyproject.toml", "setup.py"):
        shutil.copy(ROOT / name, clone / name)
    wheels = tmp_path / "wheels"
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                            "--no-build-isolation", "-w", str(wheels), str(clone)],
                           capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-2000:]
    assert "Warning" not in built.stdout + built.stderr, (built.stdout + built.stderr)[-3000:]
    assert not (clone / "build").exists() and not list(clone.glob("*.egg-info"))
    (wheel,) = wheels.glob("quad_dob_env-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for package in _tree_packages():
        assert any(name.startswith(package.replace(".", "/") + "/") for name in names), package
    assert "quad_dob_training/hyperparams/ppo.yml" in names
    assert "quad_dob_training/pretrained/residual_v3.zip" in names
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target",
                    str(site), str(wheel)], check=True, capture_output=True, timeout=600)
    user = tmp_path / "user"
    user.mkdir()
    # the wheel's copy comes first on the path, ahead of the checkout's editable install;
    # the script asserts that the modules it imports are the wheel's
    environment = {**os.environ, "PYTHONPATH": str(site)}
    result = subprocess.run([sys.executable, "-c", CLIENTS, str(site)], cwd=user,
                            env=environment, capture_output=True, text=True, timeout=1200)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "CLIENTS OK" in result.stdout
