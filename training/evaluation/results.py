"""Evaluation results others can submit: ``evaluation.json``, and leaderboards merged from
many such files.

``quad-dob evaluate`` writes ``evaluation.json``: the rows of its tables, each with the full
provenance of what was flown (project version; the env's entry point, id and version; the
scenario with its options, benchmark version, vehicle and sensing preset; the seeds; the
policy as it was named), under a ``schema`` name and ``schema_version``, with the machine and
library versions it ran on. ``schemas/evaluation.schema.json`` is its JSON Schema (draft
2020-12); every file read back is validated against it, so a hand-edited or truncated one is
named with the field that is wrong.

``merged_leaderboard`` puts the rows of files from different users and machines side by
side, one section per benchmark version and one table per flown configuration (scenario,
vehicle, sensing preset and scenario options): rows of v1 and v2, or of a scenario flown
with other options, are never ranked together, since the same scenario name then flies a
different loop. Where two files hold the same policy (the same spec and fingerprint: a
model file's or a ``py:`` module's sha256) on the same configuration, seeds and project
version, the table says whether their 95 % intervals of the RMS position error overlap:
scores from two machines should agree within their intervals, though not bit for bit.

A shipped residual policy is known by its fingerprint: rows written before bare
``residual`` followed the benchmark flown named v1's policy so, and are shown (and
compared) as ``residual:v1 (named residual)``, apart from ``residual:v2`` and
``residual:v3`` rows.
"""

from __future__ import annotations

import datetime
import json
import platform
import textwrap
from pathlib import Path
from typing import Any

import numpy as np

from quad_dob_training.evaluation.console import WIDTH, text_table

SCHEMA_NAME = "quad_dob_env.evaluation"
SCHEMA_VERSION = 1
SCHEMA_PATH = Path(__file__).parents[1] / "schemas" / "evaluation.schema.json"
# the per-row columns the provenance takes out of the flat row
PROVENANCE_KEYS = ("policy_spec", "policy_fingerprint", "benchmark", "vehicle", "sensing",
                   "env_entry_point", "env_id")


def machine() -> dict[str, str]:
    """The machine and library builds a result came from (a bit-for-bit claim's scope)."""
    import numba

    return {"python": platform.python_version(), "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "numpy": np.__version__, "numba": numba.__version__}


def results_document(rows: list[dict], seeds: list[int], scenario_options: dict[str, Any],
                     command: list[str] | None = None) -> dict[str, Any]:
    """The ``evaluation.json`` of ``rows`` (``evaluate.evaluate``'s), flown on ``seeds``
    with ``scenario_options`` (a controller flies as a residual env's base, residual
    zero; a direct model in the plain vector env; a model's env id is the one it trained
    on, none for a controller)."""
    from quad_dob_env import __version__

    documented = []
    for row in rows:
        scores = {key: _plain(value) for key, value in row.items()
                  if key not in PROVENANCE_KEYS and key != "seeds"}
        documented.append({**scores, "provenance": {
            "project_version": __version__,
            "policy_spec": row["policy_spec"],
            "policy_fingerprint": row.get("policy_fingerprint") or None,
            "scenario": row["scenario"],
            "scenario_options": {k: _plain(v) for k, v in scenario_options.items()},
            "benchmark": row["benchmark"], "vehicle": row["vehicle"],
            "sensing": row["sensing"], "seeds": [int(seed) for seed in seeds],
            "env": {"entry_point": row["env_entry_point"], "id": row["env_id"] or None,
                    "version": row["benchmark"]},
        }})
    return {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION,
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat(
                timespec="seconds"),
            "project": {"name": "quad_dob_env", "version": __version__},
            "machine": machine(), "command": list(command or []), "rows": documented}


def _plain(value: Any) -> Any:
    """JSON's own types: numpy scalars as Python numbers, NaN as null (JSON has none)."""
    if isinstance(value, (np.floating, float)):
        return None if not np.isfinite(value) else float(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def write_document(document: dict[str, Any], path: Path) -> None:
    validate(document, str(path))
    path.write_text(json.dumps(document, indent=1) + "\n")


def validate(document: Any, source: str) -> None:
    """A ValueError naming ``source``, the field and what the schema wants, unless
    ``document`` is a valid ``evaluation.json`` of this schema version."""
    import jsonschema

    schema = json.loads(SCHEMA_PATH.read_text())
    if isinstance(document, dict) and document.get("schema") == SCHEMA_NAME and \
            document.get("schema_version") != SCHEMA_VERSION:
        raise ValueError(f"{source}: schema_version {document.get('schema_version')!r}; this "
                         f"version of quad_dob_env reads {SCHEMA_VERSION}")
    error = jsonschema.exceptions.best_match(
        jsonschema.Draft202012Validator(schema).iter_errors(document))
    if error is not None:
        where = "/".join(str(part) for part in error.absolute_path) or "the top level"
        raise ValueError(f"{source} is not a valid {SCHEMA_NAME} file: at {where}: "
                         f"{error.message}")
    for index, row in enumerate(document["rows"]):  # what one field's schema cannot say
        key = "rms_position_settled"
        broken = (f"{row['crashes']} crashes of {row['flights']} flights"
                  if row["crashes"] > row["flights"] else
                  f"its interval [{row[f'{key}_low']}, {row[f'{key}_high']}] does not hold its "
                  f"mean {row[f'{key}_mean']}"
                  if not row[f"{key}_low"] <= row[f"{key}_mean"] <= row[f"{key}_high"] else
                  f"scenario {row['scenario']!r} but provenance.scenario "
                  f"{row['provenance']['scenario']!r}"
                  if row["scenario"] != row["provenance"]["scenario"] else None)
        if broken:
            raise ValueError(f"{source} is not a valid {SCHEMA_NAME} file: at rows/{index}: "
                             f"{broken}")


def read_document(path: Path) -> dict[str, Any]:
    try:
        document = json.loads(Path(path).read_text())
    except json.JSONDecodeError as error:
        raise ValueError(f"{path} is not JSON ({error.msg}, line {error.lineno})") from None
    except OSError as error:
        raise ValueError(f"{path} cannot be read ({error.strerror})") from None
    validate(document, str(path))
    return document


def configuration(row: dict) -> tuple[str, str, str, str]:
    """What a row's score depends on besides the policy and seeds: scenario, vehicle,
    sensing preset and the scenario options (the benchmark version apart)."""
    provenance = row["provenance"]
    options = {k: v for k, v in provenance["scenario_options"].items() if k != "benchmark"}
    return (provenance["scenario"], provenance["vehicle"], provenance["sensing"],
            json.dumps(options, sort_keys=True))


LEADERBOARD_HEADER = ("policy", "source", "seeds", "RMS ‖e_x‖ [m] (95 % CI)", "crashed",
                      "project", "machine", "across sources")
# what the console shows of them (the Markdown file holds all)
LEADERBOARD_CONSOLE_COLUMNS = (0, 1, 2, 3, 4, 7)


def _leaderboard_sections(sources: list[tuple[str, dict[str, Any]]]
                          ) -> list[tuple[str, str, list[list[str]]]]:
    """(benchmark, configuration heading, cells per row in ``LEADERBOARD_HEADER``'s
    order), each configuration's rows sorted by RMS position error."""
    entries = [(_cell(label), document, row) for label, document in sources
               for row in document["rows"]]
    sections = []
    for benchmark in sorted({row["provenance"]["benchmark"] for _, _, row in entries}):
        mine = [e for e in entries if e[2]["provenance"]["benchmark"] == benchmark]
        for flown in dict.fromkeys(configuration(e[2]) for e in mine):
            scenario, vehicle, sensing, options = flown
            heading = (f"{_cell(scenario)}: vehicle {_cell(vehicle)}, sensing "
                       f"{_cell(sensing)}" + ("" if options == "{}" else
                                              f", options {_cell(options)}"))
            rows = sorted((e for e in mine if configuration(e[2]) == flown),
                          key=lambda e: e[2]["rms_position_settled_mean"])
            cells = [[_cell(policy_label(row)), label, _seed_text(row["provenance"]["seeds"]),
                      f"{row['rms_position_settled_mean']:.4f} "
                      f"[{row['rms_position_settled_low']:.4f}, "
                      f"{row['rms_position_settled_high']:.4f}]",
                      f"{row['crashes']}/{row['flights']}",
                      _cell(document["project"]["version"]),
                      f"{_cell(document['machine']['processor'])}, numpy "
                      f"{_cell(document['machine']['numpy'])}",
                      _agreement(row, label, document, rows)]
                     for label, document, row in rows]
            sections.append((benchmark, heading, cells))
    return sections


def merged_leaderboard(sources: list[tuple[str, dict[str, Any]]]) -> str:
    """Markdown: per benchmark version, per configuration (``configuration``), every
    (source, row) sorted by RMS position error, with the seeds, the crash rate, the project
    version and the machine; the same policy flown on the same configuration, seeds and
    project version in two sources is marked with whether they agree (95 % intervals
    overlap)."""
    lines: list[str] = []
    shown = None
    for benchmark, heading, cells in _leaderboard_sections(sources):
        if benchmark != shown:
            lines += [f"## Benchmark {benchmark}", ""]
            shown = benchmark
        lines += [f"### {heading}", "", "| " + " | ".join(LEADERBOARD_HEADER) + " |",
                  "|" + "---|" * len(LEADERBOARD_HEADER)]
        lines += ["| " + " | ".join(row) + " |" for row in cells]
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def console_leaderboard(sources: list[tuple[str, dict[str, Any]]]) -> str:
    """``merged_leaderboard`` in 120 columns for a terminal: without the project version and
    the machine, which the Markdown file holds."""
    parts = []
    shown = None
    for benchmark, heading, cells in _leaderboard_sections(sources):
        if benchmark != shown:
            parts += [f"Benchmark {benchmark}", ""]
            shown = benchmark
        shown_columns = LEADERBOARD_CONSOLE_COLUMNS
        parts += [heading, text_table([LEADERBOARD_HEADER[k] for k in shown_columns],
                                      [[row[k] for k in shown_columns] for row in cells]), ""]
    parts.append(textwrap.fill("95 % CI: the bootstrap interval of the mean over the seeds. "
                               "The project version and machine of each row: the Markdown "
                               "(--out FILE).", WIDTH))
    return "\n".join(parts)


def _cell(text: object) -> str:
    """Text for a Markdown table cell from another user's file: one line, pipes escaped."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _seed_text(seeds: list[int]) -> str:
    if seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}-{seeds[-1]}" if len(seeds) > 1 else str(seeds[0])
    return f"{len(seeds)} seeds"


def shipped_name(row: dict) -> str | None:
    """The shipped policy (``residual:v2``) a row flew, by its fingerprint; None for any
    other."""
    from quad_dob_training.rl import SHIPPED_SHA256

    fingerprint = row["provenance"].get("policy_fingerprint")
    return next((f"residual:{benchmark}" for benchmark, digest in SHIPPED_SHA256.items()
                 if fingerprint == digest), None)


def policy_label(row: dict) -> str:
    """A row's policy as a merged leaderboard names it: a shipped policy by the name its
    fingerprint says, with the name the row gave where that differs (an older row's bare
    ``residual``, which was v1's policy)."""
    shipped = shipped_name(row)
    if shipped is None or shipped == row["policy"]:
        return row["policy"]
    return f"{shipped} (named {row['policy']})"


def _same_run(row: dict, document: dict) -> tuple:
    provenance = row["provenance"]
    return (shipped_name(row) or provenance["policy_spec"],
            provenance.get("policy_fingerprint"),
            tuple(provenance["seeds"]), document["project"]["version"])


def _agreement(row: dict, label: str, document: dict,
               rows: list[tuple[str, dict, dict]]) -> str:
    """Against the same policy (spec and fingerprint), seeds and project version in the
    other sources: "agrees with B" when the two 95 % intervals overlap, "differs from B"
    when not; "—" when no other source flew it."""
    key = _same_run(row, document)
    verdicts = []
    for other_label, other_document, other in rows:
        if other_label == label or _same_run(other, other_document) != key:
            continue
        overlap = (row["rms_position_settled_low"] <= other["rms_position_settled_high"]
                   and other["rms_position_settled_low"] <= row["rms_position_settled_high"])
        verdicts.append(f"{'agrees with' if overlap else 'differs from'} {other_label}")
    return "; ".join(verdicts) or "—"


def source_labels(paths: list[Path]) -> list[str]:
    """Short, distinct labels for merged files: the file's folder name (``results/alice/
    evaluation.json`` -> ``alice``), the whole path where two would be the same."""
    resolved = [Path(path).resolve() for path in paths]
    twice = [str(path) for path, where in zip(paths, resolved, strict=True)
             if resolved.count(where) > 1]
    if twice:
        raise ValueError(f"{twice[0]} is given twice: a leaderboard merges each file once")
    labels = [Path(path).parent.name or Path(path).stem for path in paths]
    return [label if labels.count(label) == 1 else str(path)
            for label, path in zip(labels, paths, strict=True)]
