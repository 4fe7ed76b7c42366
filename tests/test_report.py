"""report.html opens in headless Chromium without console errors and shows its plots."""

from __future__ import annotations

import os
import re
import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from quad_dob_training import cli

ERROR_MARKS = ("Uncaught", "TypeError", "ReferenceError", "SyntaxError", "Failed to load",
               "net::ERR", "console.error")


@pytest.fixture(scope="session")
def chromium() -> str:
    """Debian's chromium, installed here when absent (the test set-up needs root and apt)."""
    path = shutil.which("chromium")
    if path is None and shutil.which("apt-get") and hasattr(os, "geteuid") \
            and os.geteuid() == 0:
        subprocess.run(["apt-get", "install", "-y", "-q", "chromium"], check=False,
                       capture_output=True, timeout=900)
        path = shutil.which("chromium")
    if path is None:
        pytest.skip("Debian's chromium is not installed and cannot be installed here "
                    "(needs apt-get and root): the HTML report was not opened in a browser")
    return path


def _open(chromium: str, page, screenshot) -> list[str]:
    """Console lines that report errors, after loading ``page`` and taking a screenshot."""
    result = subprocess.run(
        [chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
         "--enable-unsafe-swiftshader", "--enable-logging=stderr", "--v=0",
         "--window-size=1200,1400", "--virtual-time-budget=5000",
         f"--screenshot={screenshot}", page.as_uri()],
        capture_output=True, text=True, timeout=120)
    console = [line for line in result.stderr.splitlines() if "CONSOLE" in line]
    return [line for line in console if any(mark in line for mark in ERROR_MARKS)]


def test_the_console_check_catches_errors(chromium, tmp_path):
    page = tmp_path / "broken.html"
    page.write_text("<html><body><script>missingFunction();</script></body></html>")
    assert _open(chromium, page, tmp_path / "broken.png")


@pytest.mark.slow
def test_evaluation_report_opens_without_console_errors_and_shows_plots(chromium, tmp_path):
    out = tmp_path / "evaluation"
    assert cli.main(["evaluate", "--benchmark", "v1", "--policies",
                     "geometric,geometric-ndob:tuned", "--scenarios", "paper-II", "--seeds",
                     "1", "--out", str(out)]) == 0
    report = out / "report.html"
    text = report.read_text()
    # offline: plotly's JavaScript is the one file beside the report, loaded relatively;
    # nothing is fetched from the network
    assert re.findall(r"<script[^>]*src=['\"]([^'\"]+)", text) == ["plotly.min.js"]
    assert (out / "plotly.min.js").is_file()
    screenshot = tmp_path / "report.png"
    assert _open(chromium, report, screenshot) == []
    pixels = np.asarray(Image.open(screenshot).convert("RGB")).reshape(-1, 3).astype(int)
    # the two policies' traces are drawn: plotly's first two colours appear in the picture
    for colour in ((31, 119, 180), (214, 39, 40)):
        assert (np.abs(pixels - colour).sum(axis=1) < 30).sum() > 200, colour
    # a report copied without its library says so where each figure would be
    (out / "plotly.min.js").unlink()
    dom = subprocess.run([chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
                          "--virtual-time-budget=2000", "--dump-dom", report.as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    assert dom.count("<p>This figure is drawn by plotly.min.js") == 2


def test_the_table_scrolls_in_its_own_box_and_the_baseline_row_compares_with_nothing(tmp_path):
    from quad_dob_training.evaluation.report import write_report

    rows = [{"scenario": "gusty-hover", "policy": "pid", "rms_position_settled_diff_mean": 0.0,
             "rms_position_settled_diff_low": 0.0, "rms_position_settled_diff_high": 0.0},
            {"scenario": "gusty-hover", "policy": "residual:v3",
             "rms_position_settled_diff_mean": -0.01, "rms_position_settled_diff_low": -0.02,
             "rms_position_settled_diff_high": -0.005}]
    columns = [("scenario", "scenario"), ("policy", "policy"),
               *((f"rms_position_settled_diff_{part}", part) for part in ("mean", "low", "high"))]
    text = write_report(tmp_path / "report.html", "t", rows, columns, {}, baseline="pid",
                        notes=["use <residual:v3>"]).read_text()
    table = re.search(r"<div class='table-box'><table>(.*?)</table></div>", text).group(1)
    baseline_row, residual_row = re.findall(r"<tr>(<td>.*?)</tr>", table)
    assert re.findall(r"<td>(.*?)</td>", baseline_row)[2:] == ["baseline"] * 3
    assert re.findall(r"<td>(.*?)</td>", residual_row)[2:] == ["-0.01", "-0.02", "-0.005"]
    assert ".table-box{overflow:auto" in text
    assert "<p class='note'>use &lt;residual:v3&gt;</p>" in text


def test_the_csv_holds_every_rows_columns_when_a_row_lost_all_its_flights(tmp_path):
    """A row whose flights were all lost has no command rate; written first, its columns
    alone made the CSV writer refuse the rows that have one (issue 57)."""
    import csv

    from quad_dob_training.evaluation.evaluate import evaluate, write_tables

    flown = evaluate(["geometric-ndob:tuned"], ["hover-calm"], [1], baseline=None)[0]
    lost = {key: value for key, value in flown.items() if not key.startswith("rms_command_rate")}
    lost.update(policy="lost-everything", crashes=1, crash_rate=1.0)
    write_tables([lost, flown], tmp_path)
    with open(tmp_path / "evaluation.csv", newline="") as file:
        written = list(csv.DictReader(file))
    assert [row["policy"] for row in written] == ["lost-everything", "geometric-ndob:tuned"]
    assert written[0]["rms_command_rate_mean"] == ""
    assert float(written[1]["rms_command_rate_mean"]) == pytest.approx(
        flown["rms_command_rate_mean"])
