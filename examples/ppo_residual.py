"""PPO for a residual policy on the native vector env, in one file read top to bottom.

In the spirit of CleanRL's ``ppo_continuous_action.py`` (its own file targets gymnasium
0.29 and no longer runs on 1.x), written afresh for ``quad_dob_env``:

- the env is Gymnasium's own ``gym.make_vec(..., vectorization_mode="vector_entry_point")``:
  N vehicles stepped by one batched core, with **same-step autoreset**, so the observation
  after an episode's end is already the next episode's first and every step of the rollout
  is a real transition (no reset steps to mask);
- a **time limit is not a crash**: on truncation the value of ``info["final_obs"]`` is
  added to the reward, so the critic does not learn that the clock running out is a
  cliff (CleanRL treats both alike);
- the residual starts out of the way: the actor's last layer is initialised near zero, so
  the first policy flies the base controller (geometric + NDOB) plus exploration noise.

    python examples/ppo_residual.py --total-timesteps 300000

prints, each iteration, the mean reward per step of the rollout and the return of the
episodes that ended, and at the end the deterministic policy's return beside the base
controller's on held-out seeds.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch
from gymnasium.vector import AutoresetMode
from torch import nn
from torch.distributions import Normal

import quad_dob_env  # noqa: F401  (registers the QuadDOB ids)


@dataclass
class Args:
    env_id: str = "QuadDOB/HoverResidual-v1"
    scenario: str = "gusty-hover"
    base_controller: str = "geometric-ndob:tuned"
    residual_effort_weight: float = 0.01  # reward cost of the residual's size, per step
    episode_seconds: float = 10.0  # the scenario's duration; shorter episodes for quick tests
    seed: int = 0
    num_envs: int = 64
    num_steps: int = 64  # per vehicle per rollout
    total_timesteps: int = 300_000
    learning_rate: float = 3e-4
    anneal_lr: bool = True
    gamma: float = 0.98
    gae_lambda: float = 0.95
    num_minibatches: int = 4
    update_epochs: int = 10
    clip_coef: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    initial_log_std: float = -1.0
    eval_seeds: int = 8  # held out: seeds from 10_000 up, training uses seed..seed+N-1


def parse_args(argv: list[str] | None = None) -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        flag = "--" + name.replace("_", "-")
        if isinstance(default, bool):
            parser.add_argument(flag, type=lambda s: s.lower() in ("1", "true", "yes"),
                                default=default)
        else:
            parser.add_argument(flag, type=type(default), default=default)
    return Args(**vars(parser.parse_args(argv)))


def make_env(args: Args, num_envs: int) -> gym.vector.VectorEnv:
    return gym.make_vec(args.env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, scenario=args.scenario,
                        base_controller=args.base_controller,
                        residual_effort_weight=args.residual_effort_weight,
                        scenario_options={"duration": args.episode_seconds})


def layer(inputs: int, outputs: int, gain: float = np.sqrt(2)) -> nn.Linear:
    linear = nn.Linear(inputs, outputs)
    nn.init.orthogonal_(linear.weight, gain)
    nn.init.zeros_(linear.bias)
    return linear


class Agent(nn.Module):
    def __init__(self, observations: int, actions: int, initial_log_std: float) -> None:
        super().__init__()
        self.critic = nn.Sequential(layer(observations, 64), nn.Tanh(), layer(64, 64),
                                    nn.Tanh(), layer(64, 1, gain=1.0))
        # gain 0.01: the first residual is almost zero, so the base flies unchanged
        self.actor_mean = nn.Sequential(layer(observations, 64), nn.Tanh(), layer(64, 64),
                                        nn.Tanh(), layer(64, actions, gain=0.01))
        self.actor_log_std = nn.Parameter(torch.full((1, actions), initial_log_std))

    def actor_parameters(self) -> list[nn.Parameter]:
        return [*self.actor_mean.parameters(), self.actor_log_std]

    def value(self, observation: torch.Tensor) -> torch.Tensor:
        return self.critic(observation).squeeze(-1)

    def act(self, observation: torch.Tensor, action: torch.Tensor | None = None):
        mean = self.actor_mean(observation)
        distribution = Normal(mean, self.actor_log_std.expand_as(mean).exp())
        if action is None:
            action = distribution.sample()
        return (action, distribution.log_prob(action).sum(-1), distribution.entropy().sum(-1),
                self.value(observation))


def evaluate(agent: Agent | None, args: Args) -> float:
    """Mean return of one episode per held-out seed; ``agent=None`` flies the base alone
    (a zero residual)."""
    env = make_env(args, args.eval_seeds)
    observation, _ = env.reset(seed=10_000)  # vehicle i is seeded 10_000 + i
    returns = np.zeros(args.eval_seeds)
    running = np.ones(args.eval_seeds, dtype=bool)
    while running.any():
        if agent is None:
            action = np.zeros((args.eval_seeds, *env.single_action_space.shape), np.float32)
        else:
            with torch.no_grad():
                action = agent.actor_mean(torch.as_tensor(observation)).numpy()
        observation, reward, terminated, truncated, _ = env.step(action)
        returns += np.where(running, reward, 0.0)
        running &= ~(terminated | truncated)
    env.close()
    return float(returns.mean())


def train(args: Args) -> tuple[Agent, dict[str, list[float]]]:
    torch.manual_seed(args.seed)
    torch.set_num_threads(1)  # 64-unit layers: threads cost more than they save
    envs = make_env(args, args.num_envs)
    n_obs, n_act = envs.single_observation_space.shape[0], envs.single_action_space.shape[0]
    agent = Agent(n_obs, n_act, args.initial_log_std)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)

    batch_size = args.num_envs * args.num_steps
    minibatch_size = batch_size // args.num_minibatches
    iterations = max(args.total_timesteps // batch_size, 1)
    observations = torch.zeros((args.num_steps, args.num_envs, n_obs))
    actions = torch.zeros((args.num_steps, args.num_envs, n_act))
    log_probs = torch.zeros((args.num_steps, args.num_envs))
    rewards = torch.zeros((args.num_steps, args.num_envs))
    ended = torch.zeros((args.num_steps, args.num_envs))  # the episode ended at this step
    values = torch.zeros((args.num_steps, args.num_envs))

    observation, _ = envs.reset(seed=args.seed)
    observation = torch.as_tensor(observation)
    episode_return = np.zeros(args.num_envs)
    history: dict[str, list[float]] = {"timesteps": [], "mean_reward": [], "episode_return": []}
    start = time.perf_counter()

    for iteration in range(1, iterations + 1):
        if args.anneal_lr:
            optimizer.param_groups[0]["lr"] = (
                1.0 - (iteration - 1) / iterations) * args.learning_rate

        # --- collect a rollout: every vehicle, num_steps steps --------------------------
        finished_returns, step_rewards = [], []
        for step in range(args.num_steps):
            observations[step] = observation
            with torch.no_grad():
                action, log_prob, _, value = agent.act(observation)
            actions[step], log_probs[step], values[step] = action, log_prob, value
            next_observation, reward, terminated, truncated, info = envs.step(action.numpy())
            episode_return += reward
            step_rewards.append(float(reward.mean()))
            reward = torch.as_tensor(reward, dtype=torch.float32)
            time_up = truncated & ~terminated
            if time_up.any():  # bootstrap from the last observation of a timed-out episode
                final = torch.as_tensor(np.stack(info["final_obs"][time_up]))
                with torch.no_grad():
                    reward[time_up] += args.gamma * agent.value(final)
            done = terminated | truncated
            finished_returns += episode_return[done].tolist()
            episode_return[done] = 0.0
            rewards[step], ended[step] = reward, torch.as_tensor(done, dtype=torch.float32)
            observation = torch.as_tensor(next_observation)

        # --- generalised advantage estimation (Schulman et al. 2016) -------------------
        with torch.no_grad():
            next_value = agent.value(observation)
        advantages = torch.zeros_like(rewards)
        last_advantage = torch.zeros(args.num_envs)
        for step in reversed(range(args.num_steps)):
            following = next_value if step == args.num_steps - 1 else values[step + 1]
            going_on = 1.0 - ended[step]
            delta = rewards[step] + args.gamma * following * going_on - values[step]
            last_advantage = delta + args.gamma * args.gae_lambda * going_on * last_advantage
            advantages[step] = last_advantage
        returns = advantages + values

        # --- PPO's clipped update (Schulman et al. 2017) -------------------------------
        b_obs, b_actions = observations.reshape(-1, n_obs), actions.reshape(-1, n_act)
        b_log_probs, b_advantages = log_probs.reshape(-1), advantages.reshape(-1)
        b_returns = returns.reshape(-1)
        for _ in range(args.update_epochs):
            order = torch.randperm(batch_size)
            for first in range(0, batch_size, minibatch_size):
                index = order[first:first + minibatch_size]
                _, new_log_prob, entropy, new_value = agent.act(b_obs[index], b_actions[index])
                ratio = (new_log_prob - b_log_probs[index]).exp()
                advantage = b_advantages[index]
                advantage = (advantage - advantage.mean()) / (advantage.std() + 1e-8)
                policy_loss = torch.max(
                    -advantage * ratio,
                    -advantage * ratio.clamp(1 - args.clip_coef, 1 + args.clip_coef)).mean()
                value_loss = 0.5 * ((new_value - b_returns[index]) ** 2).mean()
                loss = policy_loss - args.ent_coef * entropy.mean() + args.vf_coef * value_loss
                optimizer.zero_grad()
                loss.backward()
                # clipped apart: the critic's gradient (returns of tens, unnormalised) would
                # otherwise take the whole norm and leave the actor almost none
                nn.utils.clip_grad_norm_(agent.critic.parameters(), args.max_grad_norm)
                nn.utils.clip_grad_norm_(agent.actor_parameters(), args.max_grad_norm)
                optimizer.step()

        timesteps = iteration * batch_size
        history["timesteps"].append(timesteps)
        history["mean_reward"].append(float(np.mean(step_rewards)))
        history["episode_return"].append(float(np.mean(finished_returns))
                                         if finished_returns else float("nan"))
        print(f"iteration {iteration}/{iterations}  timesteps {timesteps:,}  "
              f"{timesteps / (time.perf_counter() - start):,.0f} steps/s  "
              f"mean reward {history['mean_reward'][-1]:.4f}  "
              f"episode return {history['episode_return'][-1]:.2f}")
    envs.close()
    return agent, history


if __name__ == "__main__":
    args = parse_args()
    agent, _ = train(args)
    print(f"held-out seeds 10000-{10_000 + args.eval_seeds - 1}: return "
          f"{evaluate(agent, args):.2f} with the residual, {evaluate(None, args):.2f} for the "
          "base alone")
