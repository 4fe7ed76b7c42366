import json

import pytest

from quad_dob_training.cli.commands import main
from quad_dob_training.paper import PAPER_CONTROLLERS, run_paper


@pytest.mark.slow
def test_paper_writes_tables_and_figures(tmp_path):
    rows = run_paper(["paper-IIA"], ["geometric", "geometric-ndob"], out_dir=tmp_path)
    assert [r["controller"] for r in rows] == ["geometric", "geometric-ndob"]
    table = (tmp_path / "table.md").read_text()
    assert "| paper-IIA | geometric-ndob |" in table
    assert (tmp_path / "table.csv").read_text().startswith("scenario,controller,rms_position")
    figures = sorted(p.name for p in (tmp_path / "figures").iterdir())
    assert figures == sorted(f"paper-IIA_{kind}.png" for kind in (
        "path", "states", "position_error", "attitude_error", "disturbance", "thrust"))
    assert all((tmp_path / "figures" / f).stat().st_size > 10_000 for f in figures)


@pytest.mark.slow
def test_paper_observations_hold_in_every_scenario():
    # the paper's claims: the observer lowers position error in every scenario, the error
    # stays bounded under constant disturbance, and the thrust stays under its limit
    rows = run_paper(controllers=["geometric", "geometric-ndob", "geometric-ndob:tuned"])
    by = {(r["scenario"], r["controller"]): r for r in rows}
    for scenario in ("paper-I", "paper-II", "paper-IIA", "ground-effect-landing"):
        plain = by[scenario, "geometric"]["rms_position_settled"]
        assert by[scenario, "geometric-ndob"]["rms_position_settled"] < plain
        assert by[scenario, "geometric-ndob:tuned"]["rms_position_settled"] < 0.5 * plain
    assert all(r["peak_thrust"] < r["thrust_limit"] for r in rows)
    assert all(r["ended"] == "time_limit" for r in rows)


def test_json_output_and_torque_reading(capsys):
    assert main(["paper", "--scenarios", "paper-II", "--controllers", "geometric",
                 "--torque-reading", "dx/0.6", "--json", "--no-figures",
                 "--out", "/tmp/quad_dob_paper_test"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert rows[0]["scenario"] == "paper-II" and rows[0]["controller"] == "geometric"


def test_bad_names_exit_with_the_valid_ones(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["paper", "--controllers", "lqr", "--no-figures"])
    assert exit_info.value.code == 2
    assert "unknown controller 'lqr'" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["paper", "--dt", "-1"])
    assert set(PAPER_CONTROLLERS) == {"geometric", "geometric-ndob", "geometric-ndob:tuned",
                                      "pid", "smc"}
