"""report.html stays under 1 MB for a suite's worth of flights, with plotly beside it
(issue 57: the suite's report was 25 MB, every sample of ~900 arrays written as text)."""

from __future__ import annotations

import base64
import json
import re

import numpy as np

from quad_dob_training.evaluation import report
from quad_dob_training.evaluation.report import PLOTLY_JS, write_report
from quad_dob_training.rollout import Flight

POLICIES = ("geometric-ndob:tuned", "indi", "pid", "residual:v1", "residual:v3",
            "residual:v4")


def _flight(scenario: str, controller: str, steps: int, dt: float, seed: int) -> Flight:
    """A flight of noisy arrays (the worst case for thinning), the fields the report draws
    shaped as ``fly`` records them; ``pid`` has no observer, so no estimate."""
    rng = np.random.default_rng(seed)
    time = np.arange(steps) * dt
    reference = np.stack([np.cos(time), np.sin(time), 1.0 + 0.1 * time], axis=1)

    def noisy(*shape):
        return rng.normal(size=(steps, *shape)).squeeze()

    return Flight(
        scenario=scenario, controller=controller, dt=dt, thrust_limit=40.0, time=time,
        position=reference + 0.01 * noisy(3).cumsum(axis=0), velocity=noisy(3),
        acceleration=noisy(3), rotation=np.tile(np.eye(3), (steps, 1, 1)),
        reference_position=reference, reference_velocity=noisy(3),
        reference_acceleration=noisy(3), desired_rotation=np.tile(np.eye(3), (steps, 1, 1)),
        requested_thrust=15 + noisy(), requested_rotor_thrusts=noisy(4),
        applied_thrust=15 + noisy(), disturbance_force=noisy(3), disturbance_torque=noisy(3),
        force_estimate=np.zeros((steps, 3)) if controller == "pid" else noisy(3),
        torque_estimate=noisy(3))


def _suite() -> dict[str, list[Flight]]:
    """``quad-dob evaluate --suite``'s figures: 6 policies in 16 scenarios, 12 of 1000 steps
    at 0.01 s and 4 of 1500 at 0.02 s."""
    scenarios = {f"scenario-{k}": (1000, 0.01) for k in range(12)}
    scenarios |= {f"figure8-wind-{k}": (1500, 0.02) for k in range(4)}
    return {name: [_flight(name, policy, steps, dt, seed)
                   for seed, policy in enumerate(POLICIES)]
            for name, (steps, dt) in scenarios.items()}


def _rows(flights_by_scenario):
    return [{"scenario": name, "policy": policy, "rms_mean": 0.012345, "rms_std": 0.00123}
            for name in flights_by_scenario for policy in POLICIES]


def _figures(text: str) -> list[dict]:
    return [json.loads(match) for match in re.findall(r"<script>draw\('figure-\d+',(.*?)\)"
                                                      r"</script>", text)]


def test_a_suites_report_is_under_a_megabyte_with_every_trace(tmp_path):
    flights = _suite()
    path = write_report(tmp_path / "report.html", "suite", _rows(flights),
                        [("scenario", "scenario"), ("policy", "policy"),
                         ("rms_mean", "RMS mean"), ("rms_std", "± std")], flights)
    size = path.stat().st_size
    assert size < 1_000_000, size
    figures = _figures(path.read_text())
    # every plot of the old report: per scenario the 3D paths and the 3-row time series,
    # each with all its traces (3D: the reference and 6 paths; series: 3 true disturbance
    # components, per policy the error and two thrusts, and 5 observers' 3 estimates)
    assert len(figures) == 2 * len(flights)
    assert [len(f["data"]) for f in figures[:2]] == [1 + 6, 3 + 6 * 3 + 5 * 3]
    # thinned to at least _MIN_POINTS a trace, as float32 sent in base64
    for figure in figures:
        for trace in figure["data"]:
            for axis in ("x", "y", "z") if trace["type"] == "scatter3d" else ("y",):
                assert trace[axis]["dtype"] == "f4"
                drawn = np.frombuffer(base64.b64decode(trace[axis]["bdata"]), np.float32)
                assert report._MIN_POINTS <= len(drawn) <= report._MAX_POINTS
                assert np.isfinite(drawn).all()


def test_plotly_is_one_file_beside_each_report_and_referenced_relatively(tmp_path):
    flights = {"hover": [_flight("hover", "pid", 200, 0.01, 0),
                         _flight("hover", "indi", 150, 0.01, 1)]}
    first = write_report(tmp_path / "a" / "report.html", "t", [], [], flights)
    second = write_report(tmp_path / "b" / "report.html", "t", [], [], flights)
    for path in (first, second):
        text = path.read_text()
        assert (path.parent / PLOTLY_JS).stat().st_size > 1_000_000
        assert re.findall(r"<script[^>]*src=['\"]([^'\"]+)", text) == [PLOTLY_JS]
        assert "Plotly.newPlot" in text and "plotly.js v" not in text
    # a short report is drawn at full resolution (fewer samples than a screen's width)
    figures = _figures(first.read_text())
    assert figures[1]["data"][3]["dx"] == 0.01
    # without figures there is no library to load
    bare = write_report(tmp_path / "c" / "report.html", "t", [], [], {})
    assert "<script" not in bare.read_text() and not (bare.parent / PLOTLY_JS).exists()


def test_thinning_keeps_a_noisy_series_band_and_a_smooth_series_values():
    rng = np.random.default_rng(3)
    noise = rng.normal(size=1000)
    drawn = report._envelope(noise, 8)
    assert len(drawn) == 125
    assert drawn.max() == np.float32(noise.max()) and drawn.min() == np.float32(noise.min())
    # every 8th sample alone would cut the band the full trace fills
    assert np.ptp(drawn) > np.ptp(noise[::8])
    # a smooth series is drawn at its values at the drawn times, ending at its last sample
    steps = np.arange(1003)
    smooth = np.sin(steps / 100)
    drawn = report._envelope(smooth, 8)
    at = 3.5 + 8 * np.arange(len(drawn))
    assert at[-1] <= steps[-1] < at[-1] + 8
    np.testing.assert_allclose(drawn, np.sin(at / 100), atol=1e-4)
