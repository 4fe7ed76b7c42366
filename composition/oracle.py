"""A base fed the true disturbance (``oracle:NAME``), flown in the same loop: the floor that
issue 56 asks for, where it is one.

``oracle:geometric-ndob:tuned`` is ``geometric-ndob:tuned`` with its observer replaced by a
``GivenDisturbance`` that reads, at each control step, the force and torque its model does
not hold, as the simulator applied them over the step before (``true_disturbance``):

- the external force and torque (wind, gusts, pushes), the airframe's drag, ground
  effect's extra lift and the rotors' wrench beyond their nominal model
  (``QuadrotorBatch.disturbance_force`` / ``disturbance_torque``), plus
- where the estimators are told the autopilot's command (``estimator_wrench="commanded"``,
  v4), the thrust path's own error: the wrench the motors settle at for that command
  through the battery and the throttle map, less the command
  (``QuadrotorBatch.settled_command``), force and moment. Not the motors' lag: fed back a
  step late, the lag is not a disturbance but a loop, and it chattered (465 N/s in calm
  hover, where the base flies 18 N/s). Where the estimators are told the rotors' own wrench
  (v1-v3), the thrust path is already in what they are told.

The force is the nominal model's: the drawn mass's share of it is folded in, as a real
observer lumps it into its estimate. The torque leaves out a mismatch in inertia.

Nothing here is a real vehicle's. The row says how much knowing the disturbance would gain
in the same lagged, noisy loop. It is a floor only where the base's observer estimates
nothing else. In v4 the NDOB is told the command, so its estimate also holds the motors'
lag and the rotors' ceiling, which no disturbance holds. On the figure-8s and the helices
this row flies worse than the NDOB (docs/residual-v4.md, "The truth-fed row"). Only bases
with an observer have the row: the NDOB geometric names.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from quad_dob_baselines import GeometricController, make_controller
from quad_dob_baselines.observer import GivenDisturbance, NonlinearDisturbanceObserver
from quad_dob_env.envs.core import QuadrotorBatch
from quad_dob_env.params import VehicleParams

PREFIX = "oracle:"


def is_oracle_name(name: Any) -> bool:
    """Whether ``name`` names a base fed the true disturbance."""
    return isinstance(name, str) and name.startswith(PREFIX)


def make_oracle(name: str, vehicle: VehicleParams, benchmark: str) -> GeometricController:
    """The base ``oracle:NAME`` names: NAME's controller and gains, its observer's estimate
    replaced by a given one (bound to an env's truth by ``bind_oracle``)."""
    inner = name[len(PREFIX):]
    controller = make_controller(inner, vehicle, benchmark)
    if not isinstance(getattr(controller, "observer", None), NonlinearDisturbanceObserver):
        raise ValueError(f"{name!r}: the loop's floor feeds the true disturbance to a base's "
                         f"observer, and {inner!r} has none; name a geometric base with an "
                         "observer (oracle:geometric-ndob, oracle:geometric-ndob:tuned)")
    controller.observer = GivenDisturbance()
    controller.name = name
    return controller


def true_disturbance(core: QuadrotorBatch) -> tuple[NDArray, NDArray]:
    """The force (world, N) and torque (body, N m) the base's model does not hold, over the
    last step (module docstring)."""
    told = core.estimator_wrench
    axis = core.state.rotation[:, :, 2]
    torque = core.disturbance_torque.copy()
    if core.scenario.loop.estimator_wrench == "commanded":
        thrust, moment = core.settled_command()
        torque += moment - told.moment
    else:
        thrust = told.thrust
    # the nominal model's m v̇ = m g + R T_told e3 + d at the true acceleration with the
    # settled thrust: d = (m / m_true)(R T e3 + d_true) - R T_told e3
    ratio = (core.vehicle.mass / np.asarray(core.mass).reshape(-1))[:, None]
    force = ratio * (thrust[:, None] * axis + core.disturbance_force) - told.thrust[:, None] * axis
    return force, torque


def bind_oracle(controller: Any, core: QuadrotorBatch) -> None:
    """Feed an oracle base the truth of ``core``; nothing for any other controller."""
    observer = getattr(controller, "observer", None)
    if isinstance(observer, GivenDisturbance):
        observer.source = lambda: true_disturbance(core)
