"""Every example of the README runs, so none can rot: its Python blocks in order in one
namespace (as a reader pastes them), its ``>>>`` block against the output it shows, and
every command of its bash blocks, in order, in a scratch folder.

Commands run as written but for the budgets below (a smoke run cannot train 1.5 M
timesteps or fly 20 seeds of every policy), and a command the test does not know fails
it: a new README command needs a line here.
"""

import builtins
import importlib
import re
import shlex
import sys
from pathlib import Path

import pytest
import yaml

from quad_dob_training import cli

ROOT = Path(__file__).parents[1]
README = (ROOT / "README.md").read_text()
BUDGETS = [  # (pattern, replacement): the only changes made to a README command
    (r"--timesteps \d+", "--timesteps 4096"),
    (r"--seeds 9001-9020", "--seeds 9001-9002"),
    # no cluster here: the same sweep on a Ray instance of this machine
    (r"--ray-address (auto|HOST:\d+)", "--ray-address local --workers 2"),
]
SWEEP_BUDGET = {"timesteps": 4096}  # a training sweep's config: the same grid, short runs


def _fenced() -> list[tuple[str, str]]:
    """(language, text) of every fenced block, in order."""
    blocks, language, lines = [], None, []
    for line in README.splitlines():
        if line.startswith("```") and language is None:
            language, lines = line[3:].strip(), []
        elif line.startswith("```"):
            blocks.append((language, "\n".join(lines) + "\n"))
            language = None
        elif language is not None:
            lines.append(line)
    return blocks


def _blocks(language: str) -> list[str]:
    return [text for kind, text in _fenced() if kind == language]


def _commands() -> list[str]:
    commands = []
    for block in _blocks("bash"):
        joined = re.sub(r"\\\n\s*", " ", block)
        for line in joined.splitlines():
            line = line.split("#", 1)[0].strip()
            if line:
                commands.append(line)
    return commands


def test_the_readme_has_examples_to_test():
    assert len(_blocks("python")) >= 2 and len(_commands()) >= 10


def test_every_python_block_runs_in_order():
    namespace: dict = {}
    for block in _blocks("python"):
        exec(compile(block, "README.md", "exec"), namespace)
    assert namespace["envs"].num_envs == 4096
    namespace["envs"].close()


def test_the_refusal_shown_is_the_refusal_raised():
    (block,) = [text for text in _blocks("") if text.startswith(">>>")]
    code = "\n".join(line[4:] for line in block.splitlines() if line[:4] in (">>> ", "... "))
    shown = " ".join(line for line in block.splitlines() if line[:4] not in (">>> ", "... "))
    error_type, _, message = shown.partition(": ")
    from quad_dob_env import get_vehicle, make_scenario

    with pytest.raises(getattr(builtins, error_type)) as raised:
        eval(code, {"make_scenario": make_scenario, "get_vehicle": get_vehicle})
    assert " ".join(str(raised.value).split()).startswith(" ".join(message.split()).rstrip(". "))


def _demo_recipe() -> list[str]:
    """``make demo``'s own commands, read from the Makefile (the set-up before them is what
    this suite already runs in)."""
    makefile = (ROOT / "Makefile").read_text()
    recipe = re.search(r"^demo:.*\n((?:\t.*\n)+)", makefile, flags=re.M).group(1)
    return [line.strip().replace("$(BIN)/", "") for line in recipe.splitlines()]


def _run(command: str) -> None:
    """A ``quad-dob`` command, in this process (as the console script would run it, without
    paying the imports again for each)."""
    words = shlex.split(command)
    assert words[0] == "quad-dob", command
    assert cli.main(words[1:]) == 0, command


@pytest.fixture
def no_ray_left_behind():
    """The Ray sweeps start Ray inside this process; its workers must not outlive the test
    (idle, they still take CPU from the rest of the suite)."""
    yield
    if "ray" in sys.modules:
        sys.modules["ray"].shutdown()


def test_every_readme_command_runs(tmp_path, monkeypatch, no_ray_left_behind):
    monkeypatch.chdir(tmp_path)
    ran = []
    for command in _commands():
        if command == "make test":
            continue  # it is this suite
        if command == "make demo":
            for line in _demo_recipe():
                _run(line)
            assert (tmp_path / "results" / "evaluation" / "evaluation.md").is_file()
        elif command.startswith("pip install "):
            extra = re.fullmatch(r"pip install '\.\[(\w+)\]'", command).group(1)
            pyproject = (ROOT / "pyproject.toml").read_text()
            assert re.search(rf"^{extra} = \[", pyproject, flags=re.M), command
            __import__(extra)  # the dev install this suite runs in holds every extra
        elif command.startswith("quad-dob "):
            for pattern, replacement in BUDGETS:
                command = re.sub(pattern, replacement, command)
            words = shlex.split(command)
            if words[1] == "sweep":
                config = yaml.safe_load((ROOT / words[2]).read_text())
                if config["kind"] == "train":
                    config.update(SWEEP_BUDGET)
                    short = tmp_path / Path(words[2]).name
                    short.write_text(yaml.safe_dump(config))
                    words[2] = str(short)
                else:
                    words[2] = str(ROOT / words[2])
                words += ["--out", str(tmp_path / "sweeps" / f"{len(ran)}")]
            _run(shlex.join(words))
        elif command.startswith("python -m rl_zoo3."):
            words = shlex.split(command)
            name = words[2]  # rl_zoo3.train or rl_zoo3.enjoy, run as its __main__ runs it
            arguments = [str(ROOT / w) if w.startswith("training/") else w for w in words[3:]]
            monkeypatch.setattr(sys, "argv", [name, *arguments])
            getattr(importlib.import_module(name), name.rsplit(".", 1)[-1])()
        else:
            pytest.fail(f"README command {command!r} is not one this test knows how to run")
        ran.append(command)
    assert (tmp_path / "runs" / "direct" / "model.zip").is_file()
    assert (tmp_path / "flight.gif").is_file() and (tmp_path / "gusts.mp4").is_file()
    assert list((tmp_path / "logs" / "ppo").glob("QuadDOB-HoverResidual-v1_*/*.zip"))
