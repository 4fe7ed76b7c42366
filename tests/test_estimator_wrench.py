"""What the estimators are told was applied (``LoopOptions.estimator_wrench``): the rotors'
output (v1-v3) or what the autopilot commanded, as a real stack without rotor telemetry
has it (Benchmark v4). The commanded wrench is the ticks' mean of the mixer's output after
saturation, in the autopilot's own newtons: for a command within the limits, held over the
step, that is the command itself, whatever the motors' lag and the throttle map made of it."""

import numpy as np
import pytest
from gymnasium.utils import seeding

from quad_dob_composition import ResidualVectorEnv
from quad_dob_env.envs import QuadrotorBatch
from quad_dob_env.scenarios import make_scenario


def _flown(benchmark: str, actions: np.ndarray, **options) -> QuadrotorBatch:
    n = len(actions)
    core = QuadrotorBatch(make_scenario("hover-calm", benchmark=benchmark, **options), n)
    core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
    for _ in range(3):
        core.step(actions)
    return core


@pytest.mark.parametrize(("benchmark", "options"), [
    ("v1", {"motor_lag": True}),  # a lag on the thrust
    ("v3", {}),  # speed motors, the throttle map, two ticks a step
])
def test_the_commanded_wrench_is_the_command_the_motors_made_something_else_of(benchmark,
                                                                                options):
    rng = np.random.default_rng(0)
    actions = np.column_stack([rng.uniform(-0.3, 0.3, 6), rng.uniform(-0.05, 0.05, (6, 3))])
    core = _flown(benchmark, actions, estimator_wrench="commanded", **options)
    thrust, moment = core.action_map.to_command(actions)
    assert not core.applied.saturated.any()
    np.testing.assert_allclose(core.commanded.thrust, thrust, rtol=1e-12)
    np.testing.assert_allclose(core.commanded.moment, moment, rtol=0, atol=1e-12)
    # the rotors gave something else: a lag still moving, a throttle map's error
    assert np.abs(core.applied.thrust - thrust).max() > 1e-3
    assert core.estimator_wrench is core.commanded
    # the option changes what the estimators read, never the flight
    applied = _flown(benchmark, actions, **options)
    assert applied.estimator_wrench is applied.applied
    np.testing.assert_array_equal(applied.state.position, core.state.position)
    np.testing.assert_array_equal(applied.commanded.thrust, core.commanded.thrust)


@pytest.mark.parametrize("option", ["applied", "commanded"])
def test_the_fused_pass_and_the_stages_tell_the_observers_the_same(option):
    # both paths feed the NDOB from core.estimator_wrench, and the attitude law's rotational
    # observer from the same tick values (the fused pass held to the stages, as in
    # test_residual, with the option on)
    from quad_dob_composition import residual_command

    n, steps = 4, 60
    options = {"duration": 0.3, "benchmark": "v3", "estimator_wrench": option}
    envs = [ResidualVectorEnv(n, "gusty-hover", scenario_options=options,
                              base_controller="geometric-ndob:tuned") for _ in range(2)]
    envs[1].residual = residual_command(envs[1].core, "geometric-ndob:tuned", compiled=False)
    assert envs[0].residual._fused is not None and envs[1].residual._fused is None
    for env in envs:
        env.reset(seed=3)
    actions = np.random.default_rng(4).uniform(-1, 1, (steps, n, 4))
    for step in range(steps):
        (obs, _, _, _, info), (obs2, _, _, _, info2) = (env.step(actions[step]) for env in envs)
        np.testing.assert_allclose(obs, obs2, rtol=0, atol=1e-12)
        for key in ("force_estimate", "torque_estimate"):
            np.testing.assert_allclose(info[key], info2[key], rtol=0, atol=1e-9)


def test_told_the_command_the_observer_takes_the_thrust_models_error_for_a_force():
    # v3's hover: the autopilot's thrust model is off the rotors' truth (the throttle map's
    # curvature, its hover-throttle belief). Told what the rotors gave, the NDOB sees only
    # the truth's residue; told the command, it also sees the model's error as a force, as a
    # real stack's does, and holds the height the error would cost.
    finals = {}
    for option in ("applied", "commanded"):
        env = ResidualVectorEnv(4, "hover-calm", scenario_options={
            "benchmark": "v3", "estimator_wrench": option}, base_controller="geometric-ndob:tuned")
        _, info = env.reset(seed=[1, 2, 3, 4])
        for _ in range(300):
            _, _, _, _, info = env.step(np.zeros((4, 4)))
        core = env.core
        finals[option] = (info["force_estimate"].copy(), info["torque_estimate"].copy(),
                          core.commanded.thrust - core.applied.thrust)
    (force_a, torque_a, _), (force_c, torque_c, gap) = finals["applied"], finals["commanded"]
    assert np.abs(gap).max() > 0.5  # [N] the model's error is there to be seen
    assert np.abs(force_c[:, 2] - force_a[:, 2]).max() > 0.5
    assert np.abs(torque_c - torque_a).max() > 1e-4  # the rotational observer reads it too


def test_an_unknown_estimator_wrench_is_refused_naming_the_allowed():
    with pytest.raises(ValueError, match="estimator_wrench 'telemetry'; valid: applied, "
                                         "commanded"):
        make_scenario("hover-calm", estimator_wrench="telemetry")
