"""``ReferencePolicy``: run any controller in a ``QuadrotorEnv`` loop like an SB3 model (a
controller driving an env: composition, so it lives here, not in ``baselines``)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from quad_dob_baselines import make_controller
from quad_dob_baselines.base import Controller
from quad_dob_composition.attitude_loop import AttitudeLoop


class ReferencePolicy:
    """``predict(obs) -> (action, None)`` in the env's normalised action space.

    The controller reads the env's measurement (``core.measurement``: the estimate, the
    true state with ideal sensing) and reference (not the observation), is
    reset when the env's episode restarts, and is told what the actuators applied after
    each step, as the observer needs. Where the scenario has an inner loop, the env's steps
    fly the controller's attitude law at its rate from then on (the action's moment is then
    the step's first tick's, for the record).
    """

    def __init__(self, controller: Controller | str, env: gym.Env) -> None:
        if getattr(env.unwrapped, "base_controller", None) is not None:
            raise ValueError(
                f"ReferencePolicy outputs a full command, but {env.spec.id if env.spec else env} "
                f"is a residual env (its base {env.unwrapped.base_controller['name']!r} "
                "already flies; the action is added to it): fly a controller in a direct env "
                "(QuadDOB/Hover-v1, QuadDOB/Track-v1), or give the residual env zero actions "
                "to fly its base alone")
        self.core = env.unwrapped.core
        if self.core.n != 1:
            raise ValueError(f"ReferencePolicy drives a single env, got {self.core.n} vehicles")
        self.controller = (make_controller(controller, self.core.vehicle,
                                           self.core.scenario.loop.benchmark)
                           if isinstance(controller, str) else controller)
        # with an inner loop the env's steps fly the controller's attitude law at its rate
        AttitudeLoop.install(self.core, self.controller)
        self._last_step: int | None = None
        self._last_state = None

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[NDArray[np.float32], None]:
        core, controller = self.core, self.controller
        step = int(core.step_count[0])
        if self._last_step is None or step != self._last_step + 1:
            controller.reset(1, core.vehicle, core.scenario.dt,
                             actuation=core.scenario.actuation)
        else:
            told = core.estimator_wrench  # what a real stack's estimators have
            controller.applied(self._last_state, told.thrust.copy(), told.moment.copy())
        measurement = core.measurement
        thrust, moment = controller.compute(core.time, measurement, core.reference)
        self._last_step, self._last_state = step, measurement.copy()
        return core.action_map.to_actions(thrust, moment)[0].astype(np.float32), None
