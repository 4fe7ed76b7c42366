"""Every example of the README and of the docs pages runs, so none can rot: each page's
Python blocks in order in one namespace (as a reader pastes them), its ``>>>`` blocks
against the output they show, and every command of the bash blocks of all pages, in page
order (the README, then the site's navigation), in one scratch folder.

Commands run as written but for the budgets below (a smoke run cannot train 1.5 M
timesteps or fly 20 seeds of every policy), and a command the test does not know fails
it: a new command in a page needs a line here.
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


def _pages() -> list[Path]:
    """The README, then every page of the site's navigation that is written by hand (the
    generated ones hold no examples), in order."""
    nav = yaml.safe_load((ROOT / "mkdocs.yml").read_text())["nav"]

    def walk(entry) -> list[str]:
        if isinstance(entry, str):
            return [entry]
        if isinstance(entry, list):
            return [page for item in entry for page in walk(item)]
        return [page for value in entry.values() for page in walk(value)]

    return [ROOT / "README.md", *(ROOT / "docs" / page for page in walk(nav)
                                  if (ROOT / "docs" / page).is_file())]


PAGES = _pages()
BUDGETS = [  # (pattern, replacement): the only changes made to a README command
    (r"--timesteps \d+", "--timesteps 4096"),
    (r"--seeds 9001-9020", "--seeds 9001-9002"),
    # no cluster here: the same sweep on a Ray instance of this machine
    (r"--ray-address (auto|HOST:\d+)", "--ray-address local --workers 2"),
]
SWEEP_BUDGET = {"timesteps": 4096}  # a training sweep's config: the same grid, short runs
# an evaluation sweep's config: the same grid on two of its seeds (its 24 tasks on ten seeds,
# flown locally and again on Ray, were the suite's longest test)
EVALUATION_SWEEP_BUDGET = {"seeds": "100-101"}


def _fenced(page: Path) -> list[tuple[str, str]]:
    """(language, text) of every fenced block of ``page``, in order."""
    blocks, language, lines = [], None, []
    for line in page.read_text().splitlines():
        if line.startswith("```") and language is None:
            language, lines = line[3:].strip(), []
        elif line.startswith("```"):
            blocks.append((language, "\n".join(lines) + "\n"))
            language = None
        elif language is not None:
            lines.append(line)
    return blocks


def _blocks(language: str, page: Path | None = None) -> list[str]:
    """The blocks in ``language`` of ``page`` (None: of every page, in order)."""
    return [text for one in ([page] if page else PAGES) for kind, text in _fenced(one)
            if kind == language]


def _commands(page: Path | None = None) -> list[str]:
    """The commands of ``page``'s bash blocks (None: of every page), continuations joined."""
    commands = []
    for block in _blocks("bash", page):
        joined = re.sub(r"\\\n\s*", " ", block)
        for line in joined.splitlines():
            line = line.split("#", 1)[0].strip()
            if line:
                commands.append(line)
    return commands


def test_the_pages_have_examples_to_test():
    assert len(_blocks("python")) >= 4 and len(_commands()) >= 15
    assert len(PAGES) >= 15


# pages whose Python blocks make what their commands then read (a model trained with SB3):
# their blocks run in the commands' scratch folder first, each ``learn`` given this budget
PYTHON_THEN_COMMANDS = {"evaluate-your-model.md"}
PYTHON_BUDGETS = [(r"\.learn\([\d_]+\)", ".learn(256)")]


@pytest.mark.parametrize("page", [p for p in PAGES if _blocks("python", p)
                                  and p.name not in PYTHON_THEN_COMMANDS],
                         ids=lambda page: page.name)
def test_every_python_block_of_a_page_runs_in_order(page, monkeypatch):
    monkeypatch.chdir(ROOT)  # a reader at the checkout's root
    monkeypatch.setattr(sys, "path", list(sys.path))
    namespace: dict = {}
    for block in _blocks("python", page):
        exec(compile(block, str(page.relative_to(ROOT)), "exec"), namespace)
    if page.name == "getting-started.md":
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


# what a page's commands leave behind, checked after they ran (files in the scratch folder)
LEFT_BEHIND = {
    "evaluate-your-model.md": ["hover_v3.zip", "logs/ppo/QuadDOB-HoverResidual-v3_1/*.zip",
                               "runs/hover/model.zip"],
    "residual-rl.md": ["runs/direct/model.zip", "logs/ppo/QuadDOB-HoverResidual-v1_*/*.zip"],
    "tools.md": ["flight.gif", "gusts.mp4"],
    "your-controller.md": ["results/example-pd/evaluation.json", "results/board.md"],
}


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if _commands(p)], ids=lambda p: p.name)
def test_every_command_of_a_page_runs_in_order(page, tmp_path, monkeypatch,
                                               no_ray_left_behind):
    """A page's commands in order in one scratch folder (a later command may read what an
    earlier one wrote); the pages apart, so they can run side by side."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    if page.name in PYTHON_THEN_COMMANDS:
        namespace: dict = {}
        for block in _blocks("python", page):
            for pattern, replacement in PYTHON_BUDGETS:
                block = re.sub(pattern, replacement, block)
            exec(compile(block, str(page.relative_to(ROOT)), "exec"), namespace)
    ran = []
    for command in _commands(page):
        if command == "make test":
            continue  # it is this suite
        if command == "make demo" and page.name != "README.md":
            continue  # the README's shows it too, and runs it
        if command.startswith("export PYTHONPATH="):
            # a folder of the checkout, as the page's reader has it; in this process
            folder = str(ROOT / command.partition("=")[2])
            monkeypatch.setenv("PYTHONPATH", folder)
            sys.path.insert(0, folder)
            ran.append(command)
            continue
        if command == "make demo":
            for line in _demo_recipe():
                _run(line)
            assert (tmp_path / "results" / "evaluation" / "evaluation.md").is_file()
        elif command.startswith("pip install "):
            # an extra's requirement, as the pyproject names it (outside a checkout there is
            # no '.[extra]' to install)
            requirement = re.fullmatch(r"pip install '(\w+)(>=[\d.]+)'", command)
            pyproject = (ROOT / "pyproject.toml").read_text()
            assert re.search(rf'^\w+ = \["{requirement.group(1)}{requirement.group(2)}"\]',
                             pyproject, flags=re.M), command
            __import__(requirement.group(1))  # the dev install holds every extra
        elif command.startswith("quad-dob "):
            for pattern, replacement in BUDGETS:
                command = re.sub(pattern, replacement, command)
            words = shlex.split(command)
            if words[1] == "sweep":
                config = yaml.safe_load((ROOT / words[2]).read_text())
                config.update(SWEEP_BUDGET if config["kind"] == "train"
                              else EVALUATION_SWEEP_BUDGET)
                short = tmp_path / Path(words[2]).name
                short.write_text(yaml.safe_dump(config))
                words[2] = str(short)
                words += ["--out", str(tmp_path / "sweeps" / f"{len(ran)}")]
            _run(shlex.join(words))
        elif command.startswith("python -m rl_zoo3."):
            words = shlex.split(command)
            name = words[2]  # rl_zoo3.train or rl_zoo3.enjoy, run as its __main__ runs it
            arguments = [str(ROOT / w) if w.startswith("training/") else w for w in words[3:]]
            monkeypatch.setattr(sys, "argv", [name, *arguments])
            getattr(importlib.import_module(name), name.rsplit(".", 1)[-1])()
        else:
            pytest.fail(f"command {command!r} of the pages is not one this test knows how to "
                        "run")
        ran.append(command)
    for pattern in LEFT_BEHIND.get(page.name, []):
        assert list(tmp_path.glob(pattern)), (page.name, pattern)
