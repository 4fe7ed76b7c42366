"""Building and flying one configuration, and checking it: ``build`` makes the env the
configuration asks for, as a user would; ``Flight`` resets it, flies the configuration's
actions and checks every observation, reward, flag and ``info`` (finite, in the observation
space, bools, a known ``termination_reason``, episodes truncated at the scenario's end,
invalid actions refused or ending their episode, scenario options that reached the
scenario). What it finds wrong goes to the ``Outcome`` as a ``Failure``; what counts as one
is listed in the package's docstring.
"""

from __future__ import annotations

import hashlib
import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

from .draw import INF, NAN
from .records import Failure, Outcome

REASONS = {"crashed", "out_of_bounds", "attitude_lost", "non_finite_state", "invalid_action",
           "time_limit"}


def _autoreset(value: str) -> Any:
    try:
        return AutoresetMode(value)
    except ValueError:
        return value


def build(config: dict[str, Any]) -> Any:
    """The env the configuration asks for, as a user would make it, in Gymnasium's
    wrappers the configuration names."""
    kwargs = dict(config["kwargs"])
    mode = config["mode"]
    if mode == "single":
        env = gym.make(config["env_id"], **kwargs)
    elif mode == "sync":
        vector_kwargs = {}
        if "autoreset_mode" in kwargs:
            vector_kwargs["autoreset_mode"] = _autoreset(kwargs.pop("autoreset_mode"))
        env = gym.make_vec(config["env_id"], num_envs=config["num_envs"],
                           vectorization_mode="sync", vector_kwargs=vector_kwargs, **kwargs)
    else:
        if "autoreset_mode" in kwargs:
            kwargs["autoreset_mode"] = _autoreset(kwargs["autoreset_mode"])
        env = gym.make_vec(config["env_id"], num_envs=config["num_envs"],
                           vectorization_mode="vector_entry_point", **kwargs)
    module = gym.wrappers if mode == "single" else gym.wrappers.vector
    for name in config.get("wrappers", ()):
        env = getattr(module, name)(env)
    return env

def _non_finite(value: Any, path: str = "") -> str | None:
    """The path of the first non-finite number in ``value`` (dicts, sequences, arrays)."""
    if isinstance(value, dict):
        for key, item in value.items():
            found = _non_finite(item, f"{path}[{key!r}]")
            if found:
                return found
    elif isinstance(value, np.ndarray):
        if value.dtype.kind in "fc":
            if not np.isfinite(value).all():
                return path
        elif value.dtype == object:
            for i, item in enumerate(value.reshape(-1)):
                found = _non_finite(item, f"{path}[{i}]")
                if found:
                    return found
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            found = _non_finite(item, f"{path}[{i}]")
            if found:
                return found
    elif isinstance(value, (float, complex, np.floating, np.complexfloating)):
        if not np.isfinite(value):
            return path
    return None


class Flight:
    """Flies one built env and checks every step; failures go to ``outcome``."""

    def __init__(self, config: dict[str, Any], env: Any, outcome: Outcome) -> None:
        self.config, self.env, self.outcome = config, env, outcome
        self.mode = config["mode"]
        self.vector = self.mode != "single"
        self.n = int(config["num_envs"]) if self.vector else 1
        self.rng = np.random.default_rng([config["fuzz_seed"], config["index"], 1])
        kwargs = config["kwargs"]
        self.invalid_actions = kwargs.get("invalid_actions", "raise")
        self.same_step = kwargs.get("autoreset_mode") == "SameStep"
        self.phase = "reset"
        self.digest = hashlib.blake2b(digest_size=16)  # what was observed and rewarded
        # Gymnasium's ClipAction clips ±inf to the bounds before the env sees it (NaN
        # passes), and fails on actions that are not numbers: the env's screening of those
        # is not what such a flight tests
        self.clipped = "ClipAction" in config.get("wrappers", ())

    # -- failures

    def fail(self, category: str, message: str) -> None:
        if any(f.category == category for f in self.outcome.failures):
            return
        self.outcome.failures.append(Failure(
            category, self.config["index"], self.config["fuzz_seed"], message,
            phase=self.phase, config=self.config))

    @property
    def failed(self) -> bool:
        return len(self.outcome.failures) >= 3 or any(
            f.category.startswith(("exception", "non_finite")) for f in self.outcome.failures)

    # -- what the episodes should be

    def _scenario(self) -> Any:
        env = self.env.unwrapped.envs[0] if self.mode == "sync" else self.env
        return env.unwrapped.scenario

    def expected_limit(self) -> int:
        steps = self._scenario().steps
        given = self.config["kwargs"].get("max_episode_steps")
        if isinstance(given, bool):  # Gymnasium's TimeLimit takes a flag: True is one step
            given = int(given)
        if isinstance(given, (int, np.integer)) and given >= 1:
            return min(steps, int(given))
        return steps

    def _gymnasium_time_limit(self, truncated: bool, terminated: bool, steps: int) -> bool:
        """Whether an episode ended by a ``TimeLimit`` that Gymnasium wrapped around a
        single env (gym.make, or each env of make_vec's sync mode) at the user's
        ``max_episode_steps``, shorter than the scenario."""
        given = self.config["kwargs"].get("max_episode_steps")
        if isinstance(given, bool):  # Gymnasium's TimeLimit takes a flag: True is one step
            given = int(given)
        return (self.mode in ("single", "sync") and truncated and not terminated
                and isinstance(given, (int, np.integer)) and steps == given
                < self._scenario().steps)

    def check_scenario(self) -> None:
        scenario = self._scenario()
        options = self.config["kwargs"].get("scenario_options", {})
        for name in ("dt", "duration", "substeps", "reference_start_spread", "drag",
                     "motor_lag", "actuation"):
            if name in options and name not in self.config["invalid"]:
                got = getattr(scenario.loop if name in ("drag", "motor_lag") else scenario,
                              name, None)
                want = options[name]
                same = (math.isclose(float(got), float(want), rel_tol=1e-12)
                        if isinstance(want, float) else got == want)
                if not same:
                    self.fail("option_ignored", f"scenario_options {name}={want!r} but the "
                                                f"env's scenario has {got!r}")
        if "Residual" in self.config["env_id"]:
            base = getattr(self.env.unwrapped, "base_controller", None)
            if self.mode == "sync":
                base = getattr(self.env.unwrapped.envs[0].unwrapped, "base_controller", None)
            if base is None:
                self.fail("residual_without_base", f"{self.config['env_id']} built an env "
                          "without a base controller (env.unwrapped.base_controller is None)")
        limit = self.expected_limit()
        self.limit = limit
        limits = []
        chains = (self.env.unwrapped.envs if self.mode == "sync" else
                  [] if self.vector else [self.env])
        for chain in chains:
            wrapper = chain
            while hasattr(wrapper, "env"):
                if isinstance(wrapper, gym.wrappers.TimeLimit):
                    limits.append(getattr(wrapper, "_max_episode_steps", None))
                wrapper = wrapper.env
        if self.mode == "vector_entry_point":
            core = getattr(self.env.unwrapped, "core", None)
            limits.append(getattr(core, "episode_steps", None))
        limits = [x for x in limits if isinstance(x, (int, np.integer))]
        if limits and min(limits) < limit:
            self.fail("early_truncation",
                      f"episodes would be truncated after {min(limits)} steps, before the "
                      f"scenario's end at {scenario.steps} steps (dt {scenario.dt}, duration "
                      f"{scenario.duration})"
                      + (f"; the user asked for {limit}" if limit < scenario.steps else ""))
        spec = getattr(self.env.unwrapped, "spec", None)
        reported = getattr(spec, "max_episode_steps", None)
        if reported is not None and reported != limit and limit == scenario.steps:
            self.outcome.notes.append("spec.max_episode_steps differs from the scenario's "
                                      "episode length")

    # -- checks

    def check_obs(self, obs: Any, where: str) -> None:
        space = self.env.observation_space
        if not isinstance(obs, np.ndarray):
            self.fail("bad_observation", f"{where}: observation is a {type(obs).__name__}")
            return
        if obs.dtype.kind == "f" and not np.isfinite(obs).all():
            self.fail("non_finite_observation", f"{where}: non-finite observation entries "
                      f"{np.argwhere(~np.isfinite(obs)).tolist()[:4]}")
        elif not space.contains(obs):
            self.fail("observation_outside_space", f"{where}: observation {obs.dtype} "
                      f"{obs.shape} not in {space}")

    def check_info(self, info: Any, where: str) -> None:
        if not isinstance(info, dict):
            self.fail("bad_info", f"{where}: info is a {type(info).__name__}")
            return
        found = _non_finite(info, "info")
        if found:
            self.fail("non_finite_info", f"{where}: {found} is not finite")

    def check_step(self, reward: Any, terminated: Any, truncated: Any, where: str) -> bool:
        if self.vector:
            ok = all(isinstance(x, np.ndarray) and x.shape == (self.n,)
                     for x in (reward, terminated, truncated))
            if not ok:
                self.fail("bad_step_types", f"{where}: reward/terminated/truncated are not "
                          f"arrays of shape ({self.n},)")
                return False
            if terminated.dtype != bool or truncated.dtype != bool:
                self.fail("bad_step_types", f"{where}: terminated/truncated dtypes "
                          f"{terminated.dtype}, {truncated.dtype}")
            if not np.isfinite(reward).all():
                self.fail("non_finite_reward", f"{where}: reward {reward}")
            return True
        if not isinstance(terminated, (bool, np.bool_)) or not isinstance(truncated,
                                                                          (bool, np.bool_)):
            self.fail("bad_step_types", f"{where}: terminated {type(terminated).__name__}, "
                      f"truncated {type(truncated).__name__}")
        if not isinstance(reward, (int, float, np.floating, np.integer)) or not np.isfinite(
                reward):
            self.fail("non_finite_reward", f"{where}: reward {reward!r}")
        return True

    # -- actions

    def draw_action(self) -> tuple[Any, np.ndarray | None]:
        """An action as passed, and its rows as float64 (None where it is malformed)."""
        plan, rng = self.config["actions"], self.rng
        shape = (self.n, 4) if self.vector else (4,)
        if plan["bad_rate"] and rng.random() < plan["bad_rate"] and not self.clipped:
            bad = [np.zeros(3), np.zeros((self.n + 1, 4)), np.zeros((self.n, 3)),
                   ["a", "b", "c", "d"], None, {"thrust": 1.0}]
            return bad[int(rng.integers(len(bad)))], None
        kind = plan["kind"]
        if kind == "mixed":
            kind = ["uniform", "extremes", "out_of_range", "zeros"][int(rng.integers(4))]
        if kind == "uniform":
            action = rng.uniform(-1, 1, shape)
        elif kind == "extremes":
            action = rng.choice([-1.0, 1.0], shape)
        elif kind == "out_of_range":
            action = rng.uniform(-5, 5, shape)
            if rng.random() < 0.1:
                action.reshape(-1)[int(rng.integers(action.size))] = rng.choice(
                    [1e30, -1e30, 1e308, -1e308, 5e-324])
        else:
            action = np.zeros(shape)
        if plan["nan_rate"]:
            rows = action.reshape(-1, 4)
            for row in np.flatnonzero(rng.random(len(rows)) < plan["nan_rate"]):
                rows[row, int(rng.integers(4))] = rng.choice([NAN, INF, -INF])
        container = plan["container"]
        if container == "float32":
            with np.errstate(over="ignore"):
                action = action.astype(np.float32)
        elif container == "list":
            action = action.tolist()
        rows = np.asarray(action, dtype=np.float64).reshape(-1, 4)
        if self.clipped:
            rows = np.clip(rows, -1.0, 1.0)  # what reaches the env
        return action, rows

    # -- flying

    def fly(self) -> None:
        env, config = self.env, self.config
        obs, info = env.reset(seed=config["seed"])
        self.check_obs(obs, "reset")
        self.check_info(info, "reset")
        self.phase = "checks"
        self.check_scenario()
        steps = config["steps"]
        if config["to_the_end"] and self.limit + 3 <= 2500:
            steps = max(steps, self.limit + 3)
        if config["kwargs"].get("render_mode") == "rgb_array":
            env.render()
        self.phase = "step"
        count = np.zeros(self.n, dtype=np.int64)  # steps of the current episodes
        pending = np.zeros(self.n, dtype=bool)  # next-step autoreset: reset by this step
        counting = True  # False once a single env was stepped past its end without reset
        for step in range(steps):
            if self.failed:
                return
            action, rows = self.draw_action()
            active = ~pending
            bad_rows = (~np.isfinite(rows).all(axis=1)) if rows is not None else None
            expect_refusal = rows is None or (self.invalid_actions == "raise"
                                              and bool((bad_rows & active).any()))
            where = f"step {step}"
            try:
                obs, reward, terminated, truncated, info = env.step(action)
            except ValueError as exc:
                # (a native vector env may screen the rows of vehicles it resets this step)
                if not (expect_refusal or (self.invalid_actions == "raise"
                                           and bad_rows is not None and bad_rows.any())):
                    raise
                if not str(exc).strip():
                    self.fail("exception:ValueError", f"{where}: a ValueError without a "
                              f"message for an invalid action")
                self.outcome.actions_refused += 1
                if self.mode == "sync":  # the sub-envs before the bad one did step
                    env.reset()
                    count[:] = 0
                    pending[:] = False
                continue
            self.outcome.step_calls += 1
            if expect_refusal and not self.failed:
                self.fail("invalid_action_not_refused", f"{where}: action {action!r:.120} "
                          "was flown; expected a ValueError")
            if not self.check_step(reward, terminated, truncated, where):
                return
            self.check_obs(obs, where)
            self.digest.update(np.ascontiguousarray(obs).tobytes())
            self.digest.update(np.ascontiguousarray(reward, dtype=np.float64).tobytes())
            self.check_info(info, where)
            terminated = np.atleast_1d(np.asarray(terminated, dtype=bool))
            truncated = np.atleast_1d(np.asarray(truncated, dtype=bool))
            ended = terminated | truncated
            self.outcome.vehicle_steps += int(active.sum())
            count[active] += 1
            count[pending] = 0
            for i in np.flatnonzero(ended & ~active):
                self.fail("reset_step_ended", f"{where}: vehicle {i} ended on its reset step")
            reasons = self._reasons(info, ended)
            for i in np.flatnonzero(ended & active if counting else np.zeros(self.n, bool)):
                reason = reasons[i]
                if reason is None and self._gymnasium_time_limit(truncated[i], terminated[i],
                                                                 count[i]):
                    # Gymnasium's TimeLimit (gym.make's max_episode_steps) sets truncated
                    # and leaves info alone; the env cannot see it
                    # (docs/getting-started.md, "Use it")
                    self.outcome.reasons["time_limit (Gymnasium's TimeLimit)"] += 1
                elif reason is None:
                    self.fail("missing_termination_reason",
                              f"{where}: vehicle {i} ended (terminated {terminated[i]}, "
                              f"truncated {truncated[i]}) after {count[i]} steps with no "
                              "info['termination_reason']")
                else:
                    self.outcome.reasons[reason] += 1
                    if reason not in REASONS:
                        self.fail("unknown_reason", f"{where}: reason {reason!r}")
                    elif terminated[i] == (reason == "time_limit"):
                        self.fail("reason_mismatch", f"{where}: terminated {terminated[i]}, "
                                  f"truncated {truncated[i]}, reason {reason!r}")
                if counting and truncated[i] and not terminated[i] and count[i] < self.limit:
                    self.fail("early_truncation",
                              f"{where}: vehicle {i} truncated after {count[i]} steps; its "
                              f"episode lasts {self.limit} steps")
            if counting:
                for i in np.flatnonzero(active & ~ended & (count >= self.limit)):
                    self.fail("late_truncation", f"{where}: vehicle {i} not truncated "
                              f"after {count[i]} steps; its episode lasts {self.limit}")
            if counting and bad_rows is not None and self.invalid_actions == "terminate":
                for i in np.flatnonzero(bad_rows & active):
                    if not (terminated[i] and reasons[i] == "invalid_action"):
                        self.fail("invalid_action_not_ended",
                                  f"{where}: vehicle {i} flew a non-finite action: "
                                  f"terminated {terminated[i]}, reason {reasons[i]!r}")
            if self.vector:
                if self.same_step:
                    count[ended] = 0
                    pending[:] = False
                else:
                    pending = ended & active
            elif ended[0]:
                if config["reset_after_end"]:
                    obs, info = env.reset()
                    self.check_obs(obs, f"reset after {where}")
                    self.check_info(info, f"reset after {where}")
                    count[:] = 0
                    counting = True
                else:
                    counting = False

    def _reasons(self, info: dict, ended: np.ndarray) -> list[str | None]:
        """Each vehicle's ``termination_reason`` this step, None where there is none (in
        same-step autoreset it may sit in ``final_info``)."""
        if not self.vector:
            reason = info.get("termination_reason") or None
            if reason is not None and not ended[0]:
                self.fail("spurious_termination_reason", f"the episode did not end but has "
                          f"reason {reason!r}")
            return [reason]
        top, final = self._reason_rows(info), [None] * self.n
        if isinstance(info.get("final_info"), dict):
            final = self._reason_rows(info["final_info"])
        for i in np.flatnonzero(~ended):
            if top[i] is not None:
                self.fail("spurious_termination_reason", f"vehicle {i} did not end but has "
                          f"reason {top[i]!r}")
        return [a if a is not None else b for a, b in zip(top, final, strict=True)]

    def _reason_rows(self, info: dict) -> list[str | None]:
        values, mask = info.get("termination_reason"), info.get("_termination_reason")
        if values is None:
            return [None] * self.n
        return [str(values[i]) if (mask is None or mask[i]) and values[i] else None
                for i in range(self.n)]
