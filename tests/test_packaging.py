"""``pip install .`` ships every package and data folder, quietly, and writes nothing into
the clone (setup.py points setuptools' build folders at a temporary one)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib")  # Python 3.11's; CI runs 3.11

ROOT = Path(__file__).resolve().parents[1]
# the folders pyproject.toml installs under other names
INSTALLED_AS = {"baselines": "quad_dob_baselines", "composition": "quad_dob_composition",
                "training": "quad_dob_training", "quad_dob_env": "quad_dob_env"}


def _tree_packages() -> set[str]:
    """Every folder of the source tree Python imports as a package, by its installed name:
    those with an ``__init__.py`` and the data folders beside them."""
    found = set()
    for folder, name in INSTALLED_AS.items():
        for path in (ROOT / folder).rglob("*"):
            if not path.is_dir() or path.name == "__pycache__":
                continue
            if any(part.startswith(".") for part in path.relative_to(ROOT).parts):
                continue
            if not any(child.is_file() for child in path.iterdir()):
                continue
            found.add(".".join([name, *path.relative_to(ROOT / folder).parts]))
        found.add(name)
    return found


def test_every_package_and_data_folder_of_the_tree_is_listed():
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    assert _tree_packages() - listed == set(), "folders pip install . would leave out"
    assert listed - _tree_packages() == set(), "listed packages with no folder"


@pytest.mark.slow
def test_pip_builds_a_wheel_with_every_folder_without_warnings_or_writing_into_the_clone(
        tmp_path):
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True, timeout=120)
    for name in ("pyproject.toml", "setup.py"):  # the working tree's, committed or not
        shutil.copy(ROOT / name, clone / name)
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", ".", "--no-deps",
                            "--no-build-isolation", "-w", str(tmp_path / "wheel")],
                           cwd=clone, capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-2000:]
    output = built.stdout + built.stderr
    assert "Warning" not in output and "would be ignored" not in output, output[-3000:]
    assert not (clone / "build").exists()
    assert not list(clone.glob("*.egg-info"))
    (wheel,) = (tmp_path / "wheel").glob("*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    for package in _tree_packages():
        folder = package.replace(".", "/") + "/"
        assert any(name.startswith(folder) for name in names), package
    for data in ("quad_dob_training/hyperparams/ppo.yml",
                 "quad_dob_training/pretrained/residual_v4.zip",
                 "quad_dob_training/schemas/evaluation.schema.json"):
        assert data in names
