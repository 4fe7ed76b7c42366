"""Requests too large for the machine are refused at once, with their size and the option
to change (``quad_dob_env.memory``); strings are not taken for numbers."""

from __future__ import annotations

import gymnasium as gym
import pytest

import quad_dob_env  # noqa: F401  (registers the ids)
from quad_dob_env.memory import (
    DEFAULT_MEMORY_BUDGET,
    MEMORY_BUDGET_VARIABLE,
    check_memory,
    format_bytes,
    memory_budget,
)
from quad_dob_env.scenarios import make_scenario


def test_the_budget_has_a_stated_default_and_an_environment_variable(monkeypatch):
    monkeypatch.delenv(MEMORY_BUDGET_VARIABLE, raising=False)
    assert memory_budget() == DEFAULT_MEMORY_BUDGET == 4 * 2**30
    monkeypatch.setenv(MEMORY_BUDGET_VARIABLE, "1000")
    assert memory_budget() == 1000
    check_memory(1000, "x", "y")
    with pytest.raises(ValueError, match=r"x would take 1001 B, over the memory budget of "
                                         r"1000 B: y, or raise the budget with "
                                         r"QUAD_DOB_MEMORY_BUDGET=BYTES"):
        check_memory(1001, "x", "y")
    for bad in ("lots", "-5", "0"):
        monkeypatch.setenv(MEMORY_BUDGET_VARIABLE, bad)
        with pytest.raises(ValueError, match=MEMORY_BUDGET_VARIABLE):
            memory_budget()
    assert format_bytes(1536) == "1.5 KiB" and format_bytes(8 * 2**40) == "8 TiB"


# Each asked for gigabytes before: 7.45 GiB (112 GiB uncapped) for the spread, 9 GB and
# 71 s for dt = 1e-4 on the training pool, a MemoryError for both together.
@pytest.mark.parametrize(("build", "message"), [
    (lambda: make_scenario("dryden-helix", reference_start_spread=1e7),
     r"scenario 'dryden-helix': 1 reference\(s\) tabulated over 1,000,001,001 rows .* "
     r"would take 1.01 TiB"),
    (lambda: gym.make("QuadDOB/TracksResidual-v1", scenario_options={"dt": 1e-4}),
     r"scenario 'random-tracks': 240 reference\(s\) tabulated over 100,001 rows .*"
     r"use a larger dt, a shorter duration or reference_start_spread"),
    (lambda: gym.make("QuadDOB/TracksResidual-v1",
                      scenario_options={"dt": 1e-4, "reference_start_spread": 50}),
     r"240 reference\(s\) tabulated over 600,001 rows"),
    (lambda: gym.make_vec("QuadDOB/Hover-v1", num_envs=10**9,
                          vectorization_mode="vector_entry_point"),
     r"1,000,000,000 vehicles would take 7.45 TiB.*fly fewer vehicles at once"),
])
def test_tables_and_batches_past_the_budget_are_refused_before_anything_is_tabulated(
        build, message, monkeypatch):
    import quad_dob_env.scenario as scenario_module

    tabulate = scenario_module.check_reference  # the first thing a scenario tabulates

    def guarded(member, vehicle, actuation, duration, dt):
        assert duration / dt < 50_000, "tabulated before the size was checked"
        return tabulate(member, vehicle, actuation, duration, dt)

    monkeypatch.setattr(scenario_module, "check_reference", guarded)
    with pytest.raises(ValueError, match=message):
        build()


def test_the_budget_can_be_raised_or_lowered(monkeypatch):
    monkeypatch.setenv(MEMORY_BUDGET_VARIABLE, str(10**7))
    with pytest.raises(ValueError, match=r"over the memory budget of 9\.54 MiB"):
        make_scenario("paper-none", duration=100.0)
    make_scenario("paper-none", duration=50.0)


@pytest.mark.parametrize(("options", "message"), [
    ({"wind_scale": "2"}, r"wind_scale must be a number, got str '2'"),
    ({"dt": "0.01"}, r"Scenario.dt must be a number, got str '0.01'"),
    ({"duration": True}, r"Scenario.duration must be a number, got bool True"),
    ({"initial_position": ("0", "0", "1")}, r"initial_position must be a finite 3-vector"),
])
def test_a_string_or_a_flag_is_no_number(options, message):
    with pytest.raises(ValueError, match=message):
        make_scenario("gusty-hover", **options)


def test_a_sensor_delay_line_past_the_budget_is_refused():
    # found by tests/fuzzer/: numpy was asked for 894 GiB
    with pytest.raises(ValueError, match=r"the sensing delay lines of 10,000,000,000 steps "
                                         r"for 1 vehicles would take .*SensorNoise.delay_steps"):
        gym.make("QuadDOB/Hover-v1", scenario_options={"sensors": {"delay_steps": 10**10}})
    with pytest.raises(ValueError, match=r"delay lines of 100,000,000 steps .*extra_latency"):
        gym.make("QuadDOB/Hover-v1", scenario_options={"extra_latency": 1e6})
