"""``loop_randomization`` under rl-zoo3: an ``env_wrapper`` that flies each single env in a
loop drawn by ``quad-dob train``'s own functions. A training-only key.

``loop_randomization`` (``vec_env.draw_loops``) randomises what one batch of vehicles cannot
vary per vehicle: the sensing preset, the airframe, extra latency, the motor time constant,
where asked the scenario, the wind scale and Benchmark v3's uncertain quantities. It only
shapes what a policy trains on: evaluation flies the id's named loop (``vec_env.env_options``
drops the key from a run's config, so ``quad-dob evaluate`` and ``residual:PATH`` never see
it).

No env id takes it as a keyword (the simulator knows no training options), and rl-zoo3 hands
an entry's ``env_kwargs`` to ``gym.make`` for each env, so the hyperparameter files give it
as an ``env_wrapper`` whose keyword arguments are the spec, in the form rl-zoo3's
``get_wrapper_class`` takes (a mapping of the class's dotted path to its keywords, alone or
in a list)::

    QuadDOB/TracksResidual-v2:
      env_kwargs: {scenario: random-tracks, ...}
      env_wrapper:
        quad_dob_training.rl.loop_randomization.LoopRandomization:
          groups: 4
          sensing: [mocap, mocap, gnss-imu, mocap]

``quad-dob train`` reads the same entry: ``training_options`` turns the wrapper back into
``env_kwargs["loop_randomization"]``, so its run config, and its training, are what they
were when the files held the key in ``env_kwargs`` (which ``quad-dob train`` still takes).

The two clients share every equation (``draw_loops``, ``loop_env_kwargs``)
but not the draws:

- ``quad-dob train`` (``QuadrotorSB3VecEnv``) draws the groups once from the run's seed and
  splits its N vehicles into them, group g flying vehicles ``round(g N / G)`` up to
  ``round((g + 1) N / G)``.
- Under rl-zoo3 each single env draws its own. At a reset given a seed ``s`` (SB3 seeds env i
  with ``seed + i`` at its first reset), the wrapper draws ``draw_loops(spec, s, dt)`` and
  flies group ``s mod groups`` of it: consecutive envs take the groups in turn, so the
  sensing and airframe lists keep their shares, and each range's value is drawn per env
  from its group's slice. The env is then rebuilt (``gym.make`` of its own spec with that
  loop's options; the first build is rl-zoo3's, so each env is built twice) and kept for
  every reset without a seed; a reset with another seed draws again. A first reset without
  a seed flies seed 0's draw, as ``draw_loops`` does.

rl-zoo3 applies an ``env_wrapper`` wherever it builds the env: the training envs, its
evaluation env (``--eval-freq``) and ``enjoy``, which reads the run's ``config.yml``. Those
fly the drawn loop of their seed too; for the id's named loop, delete ``env_wrapper`` from
the run's ``config.yml`` (``logs/ppo/ENV_1/ENV/config.yml``) before ``enjoy``, or evaluate
the saved zip with the id (its named loop). The wrapper must come first in the
``env_wrapper`` list: it replaces the env ``gym.make`` built, directly under SB3's
``Monitor``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from gymnasium.wrappers import OrderEnforcing, PassiveEnvChecker
from stable_baselines3.common.monitor import Monitor

from quad_dob_env.validation import unknown_name_error
from quad_dob_training.rl.vec_env import (
    LOOP_RANDOMIZATION_KEYS,
    draw_loops,
    loop_env_kwargs,
)

# the training-only env kwarg the wrapper carries, and its dotted path as the files name it
KEY = "loop_randomization"
WRAPPER = f"{__name__}.LoopRandomization"


class LoopRandomization(gym.Wrapper):
    """The env rl-zoo3 built, flown in a loop drawn from ``loop_randomization`` (the
    keyword arguments: ``groups``, ``sensing``, ``vehicle``, the ranges; ``draw_loops``),
    redrawn at each reset given a seed (the module's docstring says how). ``loop`` is the
    drawn loop flown, None before the first reset."""

    def __init__(self, env: gym.Env, **loop_randomization: Any) -> None:
        super().__init__(env)
        made = env.unwrapped.spec
        if made is None:
            raise ValueError("LoopRandomization rebuilds the env it wraps from its spec: wrap "
                             "an env made by gym.make (rl-zoo3's are)")
        self.loop_randomization = dict(loop_randomization)
        self.loop: dict[str, Any] | None = None
        self._made = made
        self._env_kwargs = dict(made.kwargs)
        self._scenario = self._env_kwargs.pop("scenario")
        # the clock the latencies are drawn on: the built scenario's step, which
        # loop_clock(scenario, kwargs) gives without building the env (here it is built)
        self._clock = float(env.unwrapped.core.scenario.dt)
        self._spaces = (env.observation_space, env.action_space)
        self._holder = self._replaced_from()
        draw_loops(self.loop_randomization, None, self._clock)  # a wrong spec fails here

    def _replaced_from(self) -> gym.Wrapper:
        """The wrapper whose ``env`` is the one ``gym.make`` built: this one, or SB3's
        ``Monitor`` below it."""
        holder: gym.Wrapper = self
        while isinstance(holder.env, Monitor):
            holder = holder.env
        made = holder.env
        if not (isinstance(made, (OrderEnforcing, PassiveEnvChecker)) or made is made.unwrapped):
            raise ValueError(f"LoopRandomization must be the first env_wrapper (directly on "
                             f"the env gym.make built, or SB3's Monitor of it): it rebuilds "
                             f"that env and would drop {type(made).__name__}")
        return holder

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        if seed is not None or self.loop is None:
            loops = draw_loops(self.loop_randomization, seed, self._clock)
            loop = loops[(0 if seed is None else seed) % len(loops)]
            if loop != self.loop:
                self._fly(loop, seed)
        return self.env.reset(seed=seed, options=options)

    def _fly(self, loop: dict[str, Any], seed: int | None) -> None:
        scenario, kwargs = loop_env_kwargs(loop, self._scenario, self._env_kwargs)
        flown = gym.make(self._made, scenario=scenario, **kwargs)
        if (flown.observation_space != self._spaces[0] or flown.action_space != self._spaces[1]
                or flown.unwrapped.core.scenario.dt != loop.get("dt", self._clock)):
            flown.close()
            raise ValueError(f"loop {loop} flies {scenario!r} with dt="
                             f"{flown.unwrapped.core.scenario.dt:g} and "
                             f"{flown.observation_space}, unlike the env's {self._scenario!r}: "
                             "a loop must keep the env's spaces, and its dt unless "
                             "control_rate sets it")
        if seed is not None:
            flown.action_space.seed(seed)  # as SB3's make_vec_env seeds the env it built
        self._holder.env.close()
        self._holder.env = flown
        self.loop = loop


def training_options(env_wrapper: Any, where: str) -> dict[str, Any]:
    """An entry's ``env_wrapper`` as the env kwargs ``quad-dob train`` takes:
    ``{"loop_randomization": SPEC}`` for ``LoopRandomization`` in any form rl-zoo3 accepts
    (the dotted path alone, a mapping of it to its keywords, or a list holding one); any
    other wrapper is refused, since the batched core flies no single envs to wrap."""
    if env_wrapper is None:
        return {}
    options: dict[str, Any] = {}
    for item in env_wrapper if isinstance(env_wrapper, list) else [env_wrapper]:
        if isinstance(item, dict) and len(item) == 1:
            name, kwargs = next(iter(item.items()))
        else:
            name, kwargs = item, {}
        if name != WRAPPER:
            raise ValueError(f"env_wrapper in {where} is {name!r}: quad-dob train flies its "
                             f"vehicles in one batched core and takes only {WRAPPER} (the "
                             "training-only loop_randomization) from rl-zoo3's env_wrapper")
        if not isinstance(kwargs, dict):
            raise ValueError(f"{WRAPPER} in {where} takes a YAML mapping of "
                             f"loop_randomization's keys, got {kwargs!r}")
        if KEY in options:
            raise ValueError(f"env_wrapper in {where} names {WRAPPER} twice")
        for key in kwargs:
            if key not in LOOP_RANDOMIZATION_KEYS:
                raise unknown_name_error(f"loop_randomization key in {where}", key,
                                         LOOP_RANDOMIZATION_KEYS)
        options[KEY] = dict(kwargs)
    return options
