"""A model flies the scenario it is asked to fly: its training benchmark chooses its base's
gains, never the loop. (``residual:v2`` asked to fly v3 once flew v2's loop under a v3
label, because the benchmark in its training config rebuilt the scenario.)"""

from __future__ import annotations

import pytest

from quad_dob_composition import make_vector_env
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.evaluation.evaluate import evaluate, parse_seeds
from quad_dob_training.policies import make_policy


@pytest.mark.parametrize("spec", ["residual:v1", "residual:v2", "residual:v3"])
@pytest.mark.parametrize("benchmark", ["v1", "v2", "v3"])
def test_a_shipped_policy_flies_the_benchmark_asked_for_on_its_own_base_gains(spec, benchmark):
    policy = make_policy(spec)
    scenario = make_scenario("gusty-hover", benchmark=benchmark)
    env = make_vector_env(2, scenario, **policy.env_kwargs())
    assert env.scenario == scenario  # the loop, the sensing and the vehicle asked for
    assert policy.base_benchmark == spec.partition(":")[2]  # the gains it learnt to correct


def test_a_v2_policy_scores_differently_in_v2_and_v3():
    rows = [evaluate(["residual:v2"], ["gusty-hover"], parse_seeds("1-2"), {}, None,
                     scenario_options={"benchmark": benchmark, "duration": 3.0})[0]
            for benchmark in ("v2", "v3")]
    assert rows[0]["rms_position_settled_mean"] != rows[1]["rms_position_settled_mean"]


def test_replay_flies_the_benchmark_it_is_told_with_that_benchmarks_policy(monkeypatch):
    from quad_dob_training.cli import replay

    seen = {}

    class BuiltError(Exception):
        pass

    def capture(n, scenario, **kwargs):
        seen.update(benchmark=scenario.loop.benchmark,
                    base_benchmark=kwargs.get("base_benchmark"))
        raise BuiltError

    monkeypatch.setattr(replay, "make_vector_env", capture)
    with pytest.raises(BuiltError):
        replay.fly_frames("residual", "hover-calm", 0, 10, (16, 8), benchmark="v2")
    assert seen == {"benchmark": "v2", "base_benchmark": "v2"}  # residual:v2, in v2's loop
    with pytest.raises(BuiltError):
        replay.fly_frames("residual:v3", "hover-calm", 0, 10, (16, 8))
    assert seen == {"benchmark": "v1", "base_benchmark": "v3"}  # the library's loop
