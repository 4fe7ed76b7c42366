"""The documentation site builds offline with no warning, its generated pages match the code,
every env id has its page, and the README stays a short front page."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import quad_dob_env

ROOT = Path(__file__).parents[1]
pytest.importorskip("mkdocs")
# Material's banner about MkDocs 2 names its switch NO_MKDOCS_2_WARNING, which the check
# for WARNING in the build's output would take for a warning
BUILD_ENV = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}


@pytest.mark.slow
def test_the_docs_build_with_warnings_as_errors(tmp_path):
    built = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                            str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                           env=BUILD_ENV, timeout=600)
    assert built.returncode == 0, built.stderr[-4000:]
    assert "WARNING" not in built.stderr, built.stderr[-4000:]
    api = (tmp_path / "site" / "api" / "index.html").read_text()
    for documented in ("quad_dob_env.envs.QuadrotorEnv", "quad_dob_baselines.base.Controller",
                       "quad_dob_composition.checks.check_controller"):
        assert f'id="{documented}"' in api  # rendered from its docstring
    assert "Observation space" in api


@pytest.mark.slow
def test_every_env_id_has_a_page_in_the_navigation_that_matches_the_env():
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        import hooks
    finally:
        sys.path.remove(str(ROOT / "docs"))
    assert hooks.stale_pages() == [], "run `python docs/hooks.py`"
    nav = yaml.safe_load((ROOT / "mkdocs.yml").read_text())["nav"]
    (environments,) = [entry["Environments"] for entry in nav if "Environments" in entry]
    listed = {page for entry in environments for page in entry.values()}
    for env_id in [*quad_dob_env.ENV_IDS, *quad_dob_env.ENV_IDS_V2]:
        page = hooks.page_name(env_id)
        assert page in listed, page
        text = (ROOT / "docs" / page).read_text()
        import gymnasium as gym

        env = gym.make(env_id)
        assert f"`{env.observation_space}`" in text and f"`{env.action_space}`" in text
        env.close()


@pytest.mark.slow
def test_a_stale_generated_page_fails_the_build(tmp_path):
    copy = tmp_path / "checkout"
    (copy / "docs").mkdir(parents=True)
    for path in (ROOT / "docs").rglob("*.md"):
        target = copy / "docs" / path.relative_to(ROOT / "docs")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(path.read_text())
    (copy / "docs" / "hooks.py").write_text((ROOT / "docs" / "hooks.py").read_text())
    for folder in ("figures",):
        (copy / "docs" / folder).symlink_to(ROOT / "docs" / folder)
    (copy / "mkdocs.yml").write_text((ROOT / "mkdocs.yml").read_text())
    (copy / "docs" / "cli.md").write_text("# Command line\n\nout of date\n")
    built = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                            str(tmp_path / "site")], cwd=copy, capture_output=True, text=True,
                           env=BUILD_ENV, timeout=600)
    assert built.returncode != 0
    assert "generated docs pages are stale: cli.md; run `python docs/hooks.py`" in built.stderr


def test_the_readme_is_a_short_front_page_with_the_set_up_commands():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) < 250
    assert "make demo" in readme and "make test" in readme
    for link in ("docs/getting-started.md", "docs/your-controller.md", "docs/cli.md"):
        assert f"]({link})" in readme and (ROOT / link).is_file()


def test_the_v3_pages_say_which_gains_their_controllers_fly():
    """v3's gain sets shipped: its pages said the controllers flew v2's until v3's search ran."""
    from quad_dob_baselines.gain_sets import GAIN_SETS

    assert any(benchmark == "v3" for _, benchmark, _ in GAIN_SETS)
    for page in sorted((ROOT / "docs" / "environments").glob("QuadDOB-*-v3.md")):
        text = page.read_text()
        assert "own search has run" not in text, page.name
        assert "the gains v3's own search chose" in text, page.name
