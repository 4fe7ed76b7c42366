"""Base controllers for residual envs: by name, and with the compiled pass where one exists."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from quad_dob_baselines import GeometricController, make_controller
from quad_dob_baselines.observer import NonlinearDisturbanceObserver
from quad_dob_composition.fused import FusedResidualStep
from quad_dob_composition.oracle import is_oracle_name, make_oracle
from quad_dob_env.params import VehicleParams


def make_base(base: Any, vehicle: VehicleParams, benchmark: str = "v1") -> Any:
    """The controller ``base`` names, with the gains its name means in ``benchmark`` on
    ``vehicle`` (``quad_dob_baselines.make_controller``), or ``base`` itself when it is
    already a controller object; ``oracle:NAME`` is NAME fed the true disturbance
    (``oracle``), bound to its env's truth by the env."""
    if is_oracle_name(base):
        return make_oracle(base, vehicle, benchmark)
    return make_controller(base, vehicle, benchmark) if isinstance(base, str) else base


def fused_pass_for(controller: Any) -> Callable[[Any], FusedResidualStep | None] | None:
    """The one compiled pass per step for the geometric controller (with or without its
    observer); None for any other, which then runs as separate stages, as does a loop
    the pass does not fly (``FusedResidualStep.flies``: the factory returns None). In that pass the
    controller's ``diagnostics`` and the observer's estimates are overwritten in place
    every step: copy what you keep."""
    if type(controller) is not GeometricController:  # a subclass may change the law
        return None
    if not isinstance(controller.observer, (NonlinearDisturbanceObserver, type(None))):
        return None  # the pass runs the NDOB's own equations (an oracle's is given)
    return lambda residual: (FusedResidualStep(controller, residual)
                             if FusedResidualStep.flies(residual.core) else None)
