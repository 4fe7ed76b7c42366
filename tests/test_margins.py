"""Delay margins (``quad_dob_training.evaluation.margins``): the grid searched upwards,
stopped at the first value that loses a flight, the latency added where the benchmark's
margin puts it."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from quad_dob_training import policies
from quad_dob_training.evaluation import margins


def _fly_losing_from(field: str, threshold: float, flown: list):
    """A stand-in for ``fly_policy``: every flight lost once ``field`` reaches
    ``threshold``; records each scenario it is given."""

    def fly(policy, scenario, seeds):
        flown.append(scenario)
        lost = getattr(scenario.loop, field) >= threshold - 1e-12
        return [SimpleNamespace(termination_reason="crashed" if lost else "time_limit")
                for _ in seeds]

    return fly


@pytest.mark.parametrize(("path", "field"), [("readings", "extra_latency"),
                                             ("pose", "unmodelled_pose_latency")])
def test_the_margin_is_the_last_grid_value_before_a_loss_on_its_path(monkeypatch, path, field):
    flown: list = []
    monkeypatch.setattr(policies, "fly_policy", _fly_losing_from(field, 0.035, flown))
    # an extra 5 ms given by the caller on the same path: the grid adds to it
    result = margins.delay_margin(None, "gusty-hover", [1, 2], {"benchmark": "v3",
                                                                field: 0.005},
                                  grid=(0.0, 0.01, 0.02, 0.03, 0.05), path=path)
    assert (result.margin, result.lost_at) == (0.02, 0.03)
    assert [getattr(s.loop, field) for s in flown] == pytest.approx(
        [0.005, 0.015, 0.025, 0.035])
    other = "extra_latency" if field != "extra_latency" else "unmodelled_pose_latency"
    assert all(getattr(s.loop, other) == 0.0 for s in flown)  # the other path untouched
    assert result.describe() == "20 ms"


def test_a_margin_never_rests_on_a_lucky_larger_value(monkeypatch):
    # lost at 10 ms, kept at 20 ms: the search stops at 10 ms, never reaching 20
    def fly(policy, scenario, seeds):
        lost = abs(scenario.loop.extra_latency - 0.01) < 1e-12
        return [SimpleNamespace(termination_reason="crashed" if lost else "")]

    monkeypatch.setattr(policies, "fly_policy", fly)
    result = margins.delay_margin(None, "hover-calm", [1], grid=(0.0, 0.01, 0.02))
    assert (result.margin, result.lost_at) == (0.0, 0.01)
    assert result.describe() == "0 ms"


def test_the_benchmarks_margin_path_and_bad_input():
    assert margins.benchmark_delay_path("v3") == "pose"
    assert margins.benchmark_delay_path("v2") == margins.benchmark_delay_path("v1") == (
        "readings")
    with pytest.raises(ValueError, match=r"delay path must be one of readings, pose.*'imu'"):
        margins.delay_margin(None, "hover-calm", [1], path="imu")
    with pytest.raises(ValueError, match="increasing latencies >= 0"):
        margins.check_grid("0.02,0.01")
