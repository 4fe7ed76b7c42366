"""The single-file trainer in examples/ learns: a loop with a wrong sign, a wrong advantage or
a broken autoreset would not raise the return it is asked to raise."""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "examples"))
ppo_residual = pytest.importorskip("ppo_residual")


@pytest.mark.slow
def test_the_examples_ppo_raises_a_residuals_return_on_a_short_budget():
    # a wide first policy (std 1) and a residual that costs: the return rises as PPO learns
    # to keep the residual small where it does not help the base
    args = ppo_residual.parse_args([
        "--total-timesteps", "40960", "--num-envs", "32", "--episode-seconds", "2",
        "--initial-log-std", "0", "--residual-effort-weight", "1.0", "--seed", "1"])
    agent, history = ppo_residual.train(args)
    first, last = np.mean(history["mean_reward"][:3]), np.mean(history["mean_reward"][-3:])
    assert last > first + 0.01, (first, last)
    assert float(agent.actor_log_std.detach().max()) < -0.05  # unneeded exploration, shed
    returns = [r for r in history["episode_return"] if np.isfinite(r)]
    assert len(returns) >= 4 and returns[-1] > returns[0]
    # the deterministic policy flies held-out seeds to the end, close to its base
    assert ppo_residual.evaluate(agent, args) > 0.9 * ppo_residual.evaluate(None, args)
