"""evaluation.json: valid against its JSON Schema, with each row's provenance, and merged with
others' files into one leaderboard that never puts two benchmark versions side by side."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import jsonschema
import pytest

from quad_dob_training.cli import main
from quad_dob_training.results import SCHEMA_PATH, merged_leaderboard, read_document


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, Path]:
    """Two evaluations as two users would make them: v2 on seeds 0-2, and v1 of one policy."""
    root = tmp_path_factory.mktemp("results")
    assert main(["evaluate", "--policies", "pid,geometric-ndob:tuned", "--scenarios",
                 "hover-step-force", "--seeds", "3", "--out", str(root / "alice")]) == 0
    assert main(["evaluate", "--benchmark", "v1", "--policies", "pid", "--scenarios",
                 "hover-step-force", "--seeds", "3", "--out", str(root / "bob")]) == 0
    return {"alice": root / "alice" / "evaluation.json", "bob": root / "bob" / "evaluation.json"}


def test_evaluation_json_is_valid_against_its_schema_and_carries_each_rows_provenance(runs):
    schema = json.loads(SCHEMA_PATH.read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    alice = json.loads(runs["alice"].read_text())
    jsonschema.validate(alice, schema)  # the library's own validator, not ours
    assert alice["schema"] == "quad_dob_env.evaluation" and alice["schema_version"] == 1
    assert alice["command"][:4] == ["quad-dob", "evaluate", "--policies",
                                    "pid,geometric-ndob:tuned"]
    pid = next(row for row in alice["rows"] if row["policy"] == "pid")
    assert pid["provenance"] == {
        "project_version": alice["project"]["version"], "policy_spec": "pid",
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
    assert "bob" not in v2
    pid = [line for line in v2.splitlines() if "| pid |" in line]
    assert "differs from carol" in pid[0] and "differs from alice" in pid[1]
    ndob = [line for line in v2.splitlines() if "| geometric-ndob:tuned |" in line]
    assert "agrees with carol" in ndob[0] and "aarch64" in ndob[1]


def test_quad_dob_leaderboard_merges_files_and_refuses_a_bad_one(runs, tmp_path, capsys):
    out = tmp_path / "board.md"
    assert main(["leaderboard", str(runs["alice"]), str(runs["bob"]), "--out", str(out)]) == 0
    assert out.read_text() == capsys.readouterr().out
    assert "| hover-step-force | pid | bob | 0-2 |" in out.read_text()
    (tmp_path / "not.json").write_text("{}")
    with pytest.raises(SystemExit):
        main(["leaderboard", str(tmp_path / "not.json")])
    assert "not.json is not a valid quad_dob_env.evaluation file: at the top level: 'schema' " \
           "is a required property" in capsys.readouterr().err
