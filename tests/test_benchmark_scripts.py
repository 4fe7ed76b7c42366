"""The benchmark scripts and the sweep build their policies for the benchmark they fly: bare
``residual`` is that benchmark's shipped policy (``policies.resolve_spec``), not v1's."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import quad_dob_training.policies as policies

BENCHMARKS = Path(__file__).parents[1] / "benchmarks"


class _BuiltError(Exception):
    """Raised by the stand-in make_policy once it has seen what the script asked for."""


@pytest.mark.parametrize("name, argv, flown", [
    ("landings_under_margin", ["--policies", "residual", "--scenarios", "hover-calm",
                               "--benchmark", "v3"], "v3"),
    ("transfer_bases", ["--residuals", "residual", "--benchmark", "v3"], "v3"),
    ("residual_vs_strongest", ["--residuals", "residual", "--scenarios", "hover-calm"], "v2"),
    ("residual_vs_strongest", ["--residuals", "residual", "--scenarios", "hover-calm",
                               "--scenario-option", "benchmark=v3"], "v3"),
])
def test_each_script_builds_bare_residual_for_the_benchmark_it_flies(monkeypatch, name, argv,
                                                                     flown, benchmark_script):
    module = benchmark_script(name)
    asked: list[str] = []

    def make_policy(spec, **options):
        asked.append(policies.resolve_spec(spec, options.get("benchmark")))
        raise _BuiltError

    monkeypatch.setattr(module, "make_policy", make_policy)
    monkeypatch.setattr(sys, "argv", [name, *argv])
    with pytest.raises(_BuiltError):
        module.main()
    assert asked == [f"residual:{flown}"]


def test_a_sweeps_evaluation_builds_bare_residual_for_the_scenarios_benchmark(monkeypatch):
    import quad_dob_env.scenarios as scenarios
    from quad_dob_training.learning import sweep

    real = scenarios.make_scenario
    monkeypatch.setattr(scenarios, "make_scenario",
                        lambda name, **options: real(name, benchmark="v2", **options))
    named: list[str] = []

    def fly_policy(policy, scenario, seeds):
        named.append(policy.name)
        raise _BuiltError

    monkeypatch.setattr(policies, "fly_policy", fly_policy)
    with pytest.raises(_BuiltError):
        sweep._evaluate_task({"params": {"policy": "residual", "scenario": "hover-calm"},
                              "seeds": [0]})
    assert named == ["residual:v2"]
