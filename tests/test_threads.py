import multiprocessing

import numpy as np
import pytest

from quad_dob_env import threads
from quad_dob_env.envs import QuadrotorVectorEnv


def _step_big_batch(queue) -> None:
    env = QuadrotorVectorEnv(512, "hover-calm")
    env.reset(seed=0)
    obs, *_ = env.step(np.zeros((512, 4)))
    queue.put(bool(np.isfinite(obs).all()))


@pytest.mark.skipif(threads.worker_count() < 2, reason="needs two cores to start workers")
def test_a_forked_child_steps_big_batches_after_the_parent_did():
    # the parent's worker threads do not exist in a forked child (AsyncVectorEnv and
    # SubprocVecEnv fork on Linux): the child must start its own instead of waiting forever
    env = QuadrotorVectorEnv(512, "hover-calm")
    env.reset(seed=0)
    env.step(np.zeros((512, 4)))
    assert threads._workers  # the parent's workers are running
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_step_big_batch, args=(queue,))
    child.start()
    child.join(timeout=120)
    if child.is_alive():
        child.kill()
        pytest.fail("the forked child hung on its first big batch")
    assert child.exitcode == 0 and queue.get(timeout=5)


def test_slices_and_their_split_never_change_results():
    kwargs = {"base_controller": "geometric-ndob:tuned"}
    threaded = QuadrotorVectorEnv(600, "dryden-helix-gusts", **kwargs)
    serial = QuadrotorVectorEnv(600, "dryden-helix-gusts", **kwargs)
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
