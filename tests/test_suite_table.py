"""benchmarks/suite_table.py over several evaluation folders: one row per benchmark,
vehicle and scenario, a column per policy (each benchmark's shipped residual in one), and a
policy's rank by the one rule."""

import csv

FIELDS = ("scenario", "policy", "policy_spec", "benchmark", "vehicle", "crashes", "flights",
          "distinct_flights", "rms_position_settled_mean", "rms_position_settled_low",
          "rms_position_settled_high")


def write_run(folder, benchmark, rows):
    folder.mkdir()
    with open(folder / "evaluation.csv", "w", newline="") as file:
        writer = csv.DictWriter(file, FIELDS)
        writer.writeheader()
        for scenario, policy, spec, crashes, rms in rows:
            writer.writerow(dict(scenario=scenario, policy=policy, policy_spec=spec,
                                 benchmark=benchmark, vehicle="paper", crashes=crashes,
                                 flights=20, distinct_flights=20,
                                 rms_position_settled_mean=rms,
                                 rms_position_settled_low=rms * 0.9,
                                 rms_position_settled_high=rms * 1.1))


def test_several_folders_make_one_table_with_a_rank(tmp_path, monkeypatch, capsys,
                                                    benchmark_script):
    write_run(tmp_path / "v1", "v1", [
        ("hover-calm", "raptor", "raptor", 0, 0.015),
        ("hover-calm", "pid", "pid", 0, 0.004),
        ("hover-calm", "residual:v1", "residual", 0, 0.003)])
    write_run(tmp_path / "v4", "v4", [
        ("hover-calm", "raptor", "raptor", 0, 0.016),
        ("hover-calm", "pid", "pid", 2, 0.002),  # lost flights rank it after raptor
        ("hover-calm", "residual:v4", "residual", 0, 0.020),
        ("hover-calm", "residual:v1", "residual:v1", 0, 0.030)])  # another benchmark's
    module = benchmark_script("suite_table")
    monkeypatch.setattr("sys.argv", ["suite_table.py", str(tmp_path / "v1"),
                                     str(tmp_path / "v4"), "--rank", "raptor"])
    module.main()
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == ("| benchmark | vehicle | scenario | raptor's rank | raptor | pid | "
                        "residual | residual:v1 |")
    assert lines[2].startswith("| v1 | paper | hover-calm | 3 of 3 | 15.0 [13.5, 16.5] |")
    assert lines[2].endswith("| 3.0 [2.7, 3.3] | — |")
    assert lines[3].startswith("| v4 | paper | hover-calm | 1 of 4 | 16.0 [14.4, 17.6] |")
    assert lines[3].endswith("| 20.0 [18.0, 22.0] | 30.0 [27.0, 33.0] |")
    assert "**2 lost**" in lines[3]
    assert len(lines) == 4
