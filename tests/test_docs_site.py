"""The documentation site reads as a manual: every list renders as a list, every scenario and
research note is in it, every env page's observation table is the env's, every link lands,
and a built page asks the network for nothing (fonts, scripts, styles: all local)."""

from __future__ import annotations

import itertools
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import quad_dob_env

ROOT = Path(__file__).parents[1]
DOCS = ROOT / "docs"
pytest.importorskip("mkdocs")

TUNING_LOGS = ("tuning-v2", "tuning-v3")  # logs kept beside the docs, not in the site
# A list item: Python-Markdown starts a list only after a blank line (or at a block's start)
LIST_ITEM = re.compile(r"^\s*([-*+]|\d+\.)\s")


def hooks():
    sys.path.insert(0, str(DOCS))
    try:
        import hooks as module
    finally:
        sys.path.remove(str(DOCS))
    return module


def broken_lists(text: str) -> list[tuple[int, str]]:
    """Each list (line number, first item) that follows a paragraph line with no blank line
    between: Python-Markdown runs it into the paragraph as literal `- ...` text. Fenced code,
    tables, headings and HTML lines are not paragraphs; a list item's own block (its
    continuation lines and nested items) is fine."""
    found, fence, block_start = [], None, None
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        fenced = re.match(r"^\s*(```|~~~)", line)
        if fence:
            if fenced and stripped.startswith(fence):
                fence = None
            continue
        if fenced:
            fence, block_start = fenced.group(1), None
            continue
        if not stripped or stripped.startswith(("#", "|", "<")):
            block_start = None
            continue
        if block_start is None:
            block_start = line
        elif LIST_ITEM.match(line) and not LIST_ITEM.match(block_start):
            found.append((number, line.strip()[:60]))
            block_start = line  # one report per list
    return found


def test_the_list_check_finds_a_list_run_into_its_paragraph():
    assert broken_lists("Some text:\n- one\n- two\n") == [(2, "- one")]
    assert broken_lists("Some text:\n\n- one\n- two\n  more\n  - nested\n") == []
    assert broken_lists("## Heading\n- one\n") == []
    assert broken_lists("```\ntext\n- not a list\n```\n| a |\n1. one\n") == []
    assert broken_lists("Text\n1. one\n") == [(2, "1. one")]


def test_no_list_runs_into_the_paragraph_above_it():
    pages = [ROOT / "README.md", *(page for page in sorted(DOCS.rglob("*.md"))
                                   if page.relative_to(DOCS).parts[0] not in TUNING_LOGS)]
    broken = [f"{page.relative_to(ROOT)}:{number}: {item}"
              for page in pages for number, item in broken_lists(page.read_text())]
    assert broken == [], ("a list needs a blank line before its first item (Python-Markdown):\n"
                          + "\n".join(broken))


def test_every_registered_scenario_is_in_the_scenarios_page():
    text = (DOCS / "scenarios.md").read_text()
    missing = [name for name in quad_dob_env.list_scenarios() if f"| `{name}` |" not in text]
    assert missing == [], f"run `python docs/hooks.py`: {missing}"


def test_every_research_note_is_in_the_navigation():
    from mkdocs.config import load_config

    config = hooks().on_config(load_config(str(ROOT / "mkdocs.yml")))
    (section,) = [entry["Research notes"] for entry in config["nav"]
                  if isinstance(entry, dict) and "Research notes" in entry]
    listed = {page for entry in section for page in entry.values()}
    notes = {f"research/{path.name}" for path in (DOCS / "research").glob("*.md")}
    assert notes and listed == notes


def test_the_readmes_links_to_files_point_at_files():
    readme = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", readme)
    local = [link for link in links if not re.match(r"[a-z]+:", link)]
    assert local and [link for link in local if not (ROOT / link).exists()] == []


def _table_columns(text: str, heading: str) -> list[tuple[int, int]]:
    """The first column's ``A-B`` (or ``A``) of the table under ``heading``."""
    section = text.split(heading, 1)[1].split("\n## ", 1)[0]
    spans = []
    for row in re.findall(r"^\| ([0-9-]+) \|", section, flags=re.M):
        first, _, last = row.partition("-")
        spans.append((int(first), int(last or first)))
    return spans


@pytest.mark.slow
def test_each_env_pages_observation_table_covers_the_envs_observation_columns():
    import gymnasium as gym

    for env_id in quad_dob_env.ALL_ENV_IDS:
        text = (DOCS / hooks().page_name(env_id)).read_text()
        spans = _table_columns(text, "## Observation space")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = gym.make(env_id)
        (size,) = env.observation_space.shape
        assert spans[0][0] == 0 and spans[-1][1] == size - 1, env_id
        assert all(b[0] == a[1] + 1 for a, b in itertools.pairwise(spans)), env_id  # no gap
        actions = _table_columns(text, "## Action space")
        assert len(actions) == env.action_space.shape[0], env_id
        env.close()


def _build(root: Path, site: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(site)], cwd=root, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})


# an external asset: a script, style sheet, font or image a page would fetch when opened
EXTERNAL_ASSET = re.compile(
    r"""<script[^>]+src=["']?(?:https?:)?//|<link[^>]+href=["']?(?:https?:)?//"""
    r"""|@import\s+(?:url\()?["']?(?:https?:)?//|url\(["']?(?:https?:)?//"""
    r"""|<img[^>]+src=["']?(?:https?:)?//|<iframe""", re.I)


@pytest.mark.slow
def test_the_built_site_fetches_nothing_from_the_network_and_holds_the_research_notes(
        tmp_path):
    built = _build(ROOT, tmp_path / "site")
    assert built.returncode == 0, built.stderr[-4000:]
    fetching = []
    for path in (tmp_path / "site").rglob("*"):
        if path.suffix in (".html", ".css", ".js"):
            for found in EXTERNAL_ASSET.finditer(path.read_text(errors="replace")):
                fetching.append(f"{path.relative_to(tmp_path)}: {found.group(0)[:80]}")
    assert fetching == [], "\n".join(fetching[:20])
    home = (tmp_path / "site" / "index.html").read_text()
    install = (tmp_path / "site" / "install" / "index.html").read_text()
    # highlighted by Pygments at build time: the tokens are spans in the page, no script
    assert 'class="language-bash highlight"' in install and '<span class="c1">' in install
    assert "fonts.googleapis" not in home and "highlight.js" not in home
    for note in (DOCS / "research").glob("*.md"):
        assert f'href="research/{note.stem}/"' in home, note.name  # in every page's nav


@pytest.mark.slow
def test_a_broken_link_or_anchor_fails_the_build(tmp_path):
    """mkdocs.yml's validation makes a link to a missing page or heading a warning, and
    --strict a failure."""
    copy = tmp_path / "checkout"
    (copy / "docs").mkdir(parents=True)
    for path in DOCS.rglob("*.md"):
        target = copy / "docs" / path.relative_to(DOCS)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(path.read_text())
    (copy / "docs" / "hooks.py").write_text((DOCS / "hooks.py").read_text())
    (copy / "docs" / "figures").symlink_to(DOCS / "figures")
    (copy / "mkdocs.yml").write_text((ROOT / "mkdocs.yml").read_text())
    page = copy / "docs" / "install.md"
    for link, message in (("(no-such-page.md)", "no-such-page.md"),
                          ("(scenarios.md#no-such-heading)", "no-such-heading")):
        page.write_text((DOCS / "install.md").read_text() + f"\nSee [this]{link}.\n")
        built = _build(copy, tmp_path / "site")
        assert built.returncode != 0 and message in built.stderr, built.stderr[-2000:]


# the research notes and the residual pages are read as findings, each under this many words
# of prose (issue 43): tables, fenced code, HTML comments and images are not counted
PROSE_LIMIT = 3000


def prose_words(text: str) -> int:
    """Words of ``text`` outside fenced code, table rows, HTML comments and image lines."""
    text = re.sub(r"<!--.*?-->", " ", text, flags=re.S)
    words, fenced = 0, False
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("```"):
            fenced = not fenced
        elif not (fenced or stripped.startswith(("|", "!["))):
            words += len(stripped.split())
    return words


def test_the_prose_counter_skips_tables_code_and_comments():
    page = ("Two words.\n\n| a | b c d |\n|---|---|\n```\nx y z\n```\n<!-- n o -->\n"
            "![p](q)\n- three more words\n")
    assert prose_words(page) == 6


@pytest.mark.parametrize("page", [*sorted((DOCS / "research").glob("*.md")),
                                  DOCS / "residual-rl.md", DOCS / "residual-v3.md"],
                         ids=lambda page: page.name)
def test_each_research_and_residual_page_stays_under_the_prose_limit(page):
    assert prose_words(page.read_text()) < PROSE_LIMIT, page
