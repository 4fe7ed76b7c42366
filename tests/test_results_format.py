"""evaluation.json: valid against its JSON Schema, with each row's provenance, and merged with
others' files into one leaderboard that never puts two benchmark versions side by side."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import jsonschema
import pytest

from quad_dob_training.cli.commands import main
from quad_dob_training.evaluation.results import SCHEMA_PATH, merged_leaderboard, read_document


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """Two evaluations as two users would make them: v2 on seeds 0-2, and v1 of one policy."""
    root = tmp_path_factory.mktemp("results")
    assert main(["evaluate", "--benchmark", "v2", "--policies", "pid,geometric-ndob:tuned",
                 "--scenarios", "hover-step-force", "--seeds", "3", "--out",
                 str(root / "alice")]) == 0
    assert main(["evaluate", "--benchmark", "v1", "--policies", "pid", "--scenarios",
                 "hover-step-force", "--seeds", "3", "--out", str(root / "bob")]) == 0
    return {"alice": root / "alice" / "evaluation.json", "bob": root / "bob" / "evaluation.json"}


@pytest.mark.slow
def test_evaluation_json_is_valid_against_its_schema_and_carries_each_rows_provenance(runs):
    schema = json.loads(SCHEMA_PATH.read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    alice = json.loads(runs["alice"].read_text())
    jsonschema.validate(alice, schema)  # the library's own validator, not ours
    assert alice["schema"] == "quad_dob_env.evaluation" and alice["schema_version"] == 1
    assert alice["command"][:6] == ["quad-dob", "evaluate", "--benchmark", "v2",
                                    "--policies", "pid,geometric-ndob:tuned"]
    pid = next(row for row in alice["rows"] if row["policy"] == "pid")
    assert pid["provenance"] == {
        "project_version": alice["project"]["version"], "policy_spec": "pid",
        "policy_fingerprint": None,
        "scenario": "hover-step-force", "scenario_options": {"benchmark": "v2"},
        "benchmark": "v2", "vehicle": "paper", "sensing": "mocap", "seeds": [0, 1, 2],
        "env": {"entry_point": "quad_dob_composition:ResidualVectorEnv", "id": None,
                "version": "v2"}}
    assert pid["flights"] == 3 and pid["rms_position_settled_low"] <= \
        pid["rms_position_settled_mean"] <= pid["rms_position_settled_high"]
    bob = read_document(runs["bob"])
    assert bob["rows"][0]["provenance"]["sensing"] == "ideal"
    assert bob["rows"][0]["provenance"]["benchmark"] == "v1"


def test_a_damaged_file_is_named_with_the_field_that_is_wrong(runs, tmp_path):
    document = json.loads(runs["alice"].read_text())
    broken = copy.deepcopy(document)
    del broken["rows"][1]["provenance"]["seeds"]
    path = tmp_path / "broken.json"
    path.write_text(json.dumps(broken))
    with pytest.raises(ValueError, match=r"broken.json is not a valid quad_dob_env.evaluation "
                                         r"file: at rows/1/provenance: 'seeds' is a required"):
        read_document(path)
    future = {**document, "schema_version": 2}
    path.write_text(json.dumps(future))
    with pytest.raises(ValueError, match="schema_version 2; this version of quad_dob_env "
                                         "reads 1"):
        read_document(path)
    path.write_text(json.dumps(document)[:-40])
    with pytest.raises(ValueError, match=r"broken.json is not JSON"):
        read_document(path)


@pytest.mark.slow
def test_merged_leaderboard_keeps_benchmarks_apart_and_says_where_machines_agree(runs):
    alice = read_document(runs["alice"])
    carol = copy.deepcopy(alice)  # the same run from another machine, one score off
    carol["machine"]["processor"] = "aarch64"
    for row in carol["rows"]:
        if row["policy"] == "pid":
            for key in ("mean", "low", "high"):
                row[f"rms_position_settled_{key}"] *= 3.0
    board = merged_leaderboard([("alice", alice), ("bob", read_document(runs["bob"])),
                                ("carol", carol)])
    v1, v2 = board.split("## Benchmark v2")
    assert "## Benchmark v1" in v1 and "| bob |" in v1 and "alice" not in v1
    assert "bob" not in v2 and "### hover-step-force: vehicle paper, sensing mocap" in v2
    pid = [line for line in v2.splitlines() if line.startswith("| pid |")]
    assert "differs from carol" in pid[0] and "differs from alice" in pid[1]
    ndob = [line for line in v2.splitlines() if line.startswith("| geometric-ndob:tuned |")]
    assert "agrees with carol" in ndob[0] and "aarch64" in ndob[1]


def test_rows_flown_another_way_are_never_ranked_or_matched_together(runs):
    """Another vehicle, another sensing preset, other scenario options, another model
    under the same spec or another project version: each its own table, or no match."""
    alice = read_document(runs["alice"])
    dave = copy.deepcopy(alice)
    for row in dave["rows"]:
        row["provenance"]["sensing"] = "ideal"
        row["provenance"]["scenario_options"] = {"benchmark": "v2", "sensing": "ideal"}
    erin = copy.deepcopy(alice)
    for row in erin["rows"]:
        row["provenance"]["policy_fingerprint"] = "0" * 64  # another file under that spec
    board = merged_leaderboard([("alice", alice), ("dave", dave), ("erin", erin)])
    tables = board.split("### ")[1:]
    assert len(tables) == 2 and "sensing ideal, options {\"sensing\": \"ideal\"}" in tables[1]
    assert "dave" not in tables[0] and "alice" not in tables[1]
    assert "agrees" not in board and "differs" not in board  # erin's model is not alice's
    frank = copy.deepcopy(alice)
    frank["project"]["version"] = "0.2.0"
    assert "agrees" not in merged_leaderboard([("alice", alice), ("frank", frank)])


@pytest.mark.parametrize(("change", "message"), [
    (lambda row: row.update(crashes=7), "at rows/0: 7 crashes of 3 flights"),
    (lambda row: row.update(rms_position_settled_low=row["rms_position_settled_high"] + 1),
     "at rows/0: its interval"),
    (lambda row: row.update(scenario="hover-calm"),
     "at rows/0: scenario 'hover-calm' but provenance.scenario 'hover-step-force'"),
    (lambda row: row.update(policy="pid | ## Benchmark v9"), r"at rows/0/policy: .* does not "
                                                             r"match"),
])
def test_a_file_that_passes_field_by_field_but_does_not_hold_together_is_refused(
        runs, tmp_path, change, message):
    document = json.loads(runs["alice"].read_text())
    change(document["rows"][0])
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(document))
    with pytest.raises(ValueError, match=message):
        read_document(path)


def test_quad_dob_leaderboard_merges_files_and_refuses_a_bad_one(runs, tmp_path, capsys):
    out = tmp_path / "board.md"
    assert main(["leaderboard", str(runs["alice"]), str(runs["bob"]), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| pid | bob | 0-2 |" in out.read_text()
    # the console's table fits 120 columns: the same rows, the machine left to the file
    assert max(len(line) for line in printed.splitlines()) <= 120
    assert re.search(r"^pid +bob +0-2 ", printed, re.MULTILINE)
    assert "numpy" in out.read_text() and "numpy" not in printed
    with pytest.raises(SystemExit):
        main(["leaderboard", str(runs["alice"]), str(runs["alice"])])
    assert "evaluation.json is given twice" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["evaluate", "--json", "--merge", str(runs["alice"])])
    assert "--merge writes leaderboard-merged.md into --out" in capsys.readouterr().err
    (tmp_path / "not.json").write_text("{}")
    with pytest.raises(SystemExit):
        main(["leaderboard", str(tmp_path / "not.json")])
    assert "not.json is not a valid quad_dob_env.evaluation file: at the top level: 'schema' " \
           "is a required property" in capsys.readouterr().err


def test_the_schema_takes_every_benchmark_the_tools_fly():
    """A benchmark the tools fly whose results the schema refused would fail every
    evaluation in it after its flights (v4's did, until issue 55)."""
    import json

    from quad_dob_env.benchmark import BENCHMARKS
    from quad_dob_training.evaluation.results import SCHEMA_PATH

    provenance = json.loads(SCHEMA_PATH.read_text())["$defs"]["provenance"]["properties"]
    assert provenance["benchmark"]["enum"] == list(BENCHMARKS)
    assert provenance["env"]["properties"]["version"]["enum"] == list(BENCHMARKS)
