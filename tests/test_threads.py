import multiprocessing

import numpy as np
import pytest
from gymnasium.utils import seeding

from quad_dob_composition import make_vector_env, residual_command
from quad_dob_env import threads
from quad_dob_env.envs import QuadrotorBatch, QuadrotorVectorEnv
from quad_dob_env.residual import ResidualCommand
from quad_dob_env.scenarios import make_scenario

_BIG_BATCHES = {"bare": ("dryden-helix-gusts", None),  # its turbulence uses the pool
                "residual": ("hover-calm", "geometric-ndob")}


def _big_batch(kind: str) -> QuadrotorVectorEnv:
    scenario, base = _BIG_BATCHES[kind]
    env = make_vector_env(512, scenario, base_controller=base)
    env.reset(seed=0)
    env.step(np.zeros((512, 4)))
    return env


def _step_big_batch(kind: str, queue) -> None:
    obs, *_ = _big_batch(kind).step(np.zeros((512, 4)))
    queue.put(bool(np.isfinite(obs).all()))


@pytest.mark.skipif(threads.worker_count() < 2, reason="needs two cores to start workers")
@pytest.mark.parametrize("kind", sorted(_BIG_BATCHES))
def test_a_forked_child_steps_big_batches_after_the_parent_did(kind):
    # the parent's worker threads do not exist in a forked child (AsyncVectorEnv and
    # SubprocVecEnv fork on Linux): the child must start its own instead of waiting forever
    env = _big_batch(kind)
    assert threads._workers  # they are running
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_step_big_batch, args=(kind, queue))
    child.start()
    child.join(timeout=120)
    if child.is_alive():
        child.kill()
        pytest.fail("the forked child hung on its first big batch")
    assert child.exitcode == 0 and queue.get(timeout=5)
    env.step(np.zeros((512, 4)))  # and the parent's workers still answer


def test_slices_and_their_split_never_change_results():
    kwargs = {"base_controller": "geometric-ndob:tuned"}
    threaded = make_vector_env(600, "dryden-helix-gusts", **kwargs)
    serial = make_vector_env(600, "dryden-helix-gusts", **kwargs)
    actions = np.random.default_rng(0).uniform(-0.3, 0.3, (30, 600, 4))
    threaded.reset(seed=1)
    serial.reset(seed=1)
    for step in range(30):
        for kernel in list(threads._lead):  # the caller's share: none, some, the most
            threads._lead[kernel] = (0.0, 37.0, 1e9)[step % 3]
        obs, rewards, *_ = threaded.step(actions[step])
        with threads._lock:  # held, as by another thread: every kernel runs serially
            expected, expected_rewards, *_ = serial.step(actions[step])
        np.testing.assert_array_equal(obs, expected)
        np.testing.assert_array_equal(rewards, expected_rewards)
    assert threads._lead  # the threaded env did split its batches


def _residual_twins(n: int, scenario: str, options: dict) -> list[ResidualCommand]:
    """The same vehicles flown by the fused pass (threaded) and by the stages."""
    twins = []
    for compiled in (True, False):
        core = QuadrotorBatch(make_scenario(scenario, **options), n)
        core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
        twins.append(residual_command(core, "geometric-ndob:tuned", compiled=compiled))
        twins[-1].restart(np.arange(n))
    return twins


def test_the_fused_pass_follows_the_tables_and_full_resets():
    # the fused pass gathers its arguments once: when the core's tables
    # grow (flown past the scenario's end) or a full reset replaces the observer's arrays,
    # it must gather them again. The separate stages are the reference.
    n = 512
    fused, staged = _residual_twins(n, "dryden-helix-gusts", {"duration": 0.2})
    residuals = np.random.default_rng(2).uniform(-0.3, 0.3, (60, n, 4))
    tables = set()
    for step in range(60):
        if step == 33:  # a full reset, as env.reset() does
            for twin in (fused, staged):
                twin.core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
                twin.restart(np.arange(n))
        fused.step(residuals[step])
        staged.step(residuals[step])
        tables.add(id(fused.core.reference_table))
        np.testing.assert_allclose(fused.core.obs, staged.core.obs, rtol=0, atol=1e-12)
        np.testing.assert_allclose(fused.extra_observation, staged.extra_observation, rtol=0,
                                   atol=1e-9)
        np.testing.assert_allclose(fused.force_estimate, staged.force_estimate, rtol=0,
                                   atol=1e-9)
    assert len(tables) >= 2  # 20-step tables: they grew


def test_the_bare_core_flies_past_its_tables_threaded_as_serially():
    n = 512
    cores = [QuadrotorBatch(make_scenario("gusty-hover", duration=0.2), n) for _ in range(2)]
    for core in cores:
        core.reset(np.arange(n), [seeding.np_random(i)[0] for i in range(n)])
    actions = np.random.default_rng(3).uniform(-0.1, 0.1, (50, n, 4))
    for step in range(50):  # 20-step tables: they grow twice
        cores[0].step(actions[step])
        with threads._lock:
            cores[1].step(actions[step])
        np.testing.assert_array_equal(cores[0].obs, cores[1].obs)
        np.testing.assert_array_equal(cores[0].disturbance_force, cores[1].disturbance_force)
    assert cores[0].reference_table.shape[0] > 21


