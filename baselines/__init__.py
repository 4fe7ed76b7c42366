"""Reference controllers, all batched, behind one interface (docs/design.md principle 2).

The folder ``baselines/`` installs as ``quad_dob_baselines``. It may import the simulator's
layers below its envs (``quad_dob_env.params``, ``so3``, ``flatness``, ``dynamics``,
``benchmark``, the reference type, ...; the order: docs/design.md, "Layers"), never its
envs, residual or wrappers, nor ``quad_dob_composition`` or ``quad_dob_training``.

- ``base``: the ``Controller`` template (reset / compute / applied).
- ``geometric_kernels``: the geometric controller's and the observer's equations, once per vehicle,
  compiled (the modules below call them for the batch).
- ``attitude``: desired attitude from a thrust vector and heading, with analytic Ωd, Ω̇d.
- ``geometric``: Lee–Leok–McClamroch 2010 on SE(3); with an observer, geometric + NDOB.
- ``observer``: the nonlinear disturbance observer (Chen 2000 form).
- ``pid``: cascaded PID; ``smc``: sliding-mode control.
- ``indi``: incremental nonlinear dynamic inversion on the geometric law (acceleration
  feedback from the IMU and the rotor-speed telemetry); ``l1``: L1 adaptive augmentation
  of the geometric law; ``filters``: the low-pass filters they run; ``neural_fly``:
  Neural-Fly-Constant (NF-C) and Neural-Fly's nonlinear baseline, their composite law with
  NF-C's adaptation and with integral action.
- ``inner``: their attitude laws, compiled per vehicle, for an inner loop that runs them
  at its own rate (``InnerLaw``, what ``Controller.inner_law`` hands it).
- ``raptor``: RAPTOR's foundation policy (Eschmann et al. 2025) as a controller, its weights
  read from the ``foundation-policy`` package's checkpoint.
- ``crazyflie_lee``: the Lee law as the Crazyflie's firmware flies it (position and
  attitude integrals, no Ω̇d term), its gains in the firmware's names.

- ``plugins``: a user's controller by ``py:package.module:Name`` or by the name an
  installed package registers (entry-point group ``quad_dob_env.controllers``).
- ``gain_sets``: what each name's gains are per benchmark and vehicle (v2's tuned with a
  latency and motor margin).

``make_controller(name, vehicle, benchmark)`` builds one by the name the CLI, evaluation and the
residual wrapper use: ``geometric``, ``geometric-ndob`` (the paper's observer gains),
``geometric-ndob:tuned`` (tuned observer rates, the paper's gains: the recommended base),
``geometric-ndob:gains-tuned`` (its gains tuned too), ``geometric-integral`` (integral
action on position instead of an observer), ``indi``, ``indi-outer`` (INDI's outer loop
alone under Lee's attitude law, first-order 5 Hz filter: the INDI Neural-Fly flew), ``l1``,
``l1-matched`` (L1 compensating the thrust axis's part alone, as Neural-Fly's),
``nf-constant`` (Neural-Fly's NF-C), ``nf-baseline`` (their nonlinear baseline), ``pid``,
``smc``, ``raptor`` (an outside learned policy, RAPTOR's, with the extra ``raptor``), and
``crazyflie-lee`` (the Crazyflie firmware's Lee law, which Crazyswarm2's logs flew).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from quad_dob_baselines import plugins
from quad_dob_baselines.base import Controller
from quad_dob_baselines.crazyflie_lee import FirmwareLeeController, FirmwareLeeGains
from quad_dob_baselines.gain_sets import (
    BENCHMARK_INPUTS,
    GAIN_SETS,
    MARGIN_LOSSES,
    GainSet,
    gain_set,
)
from quad_dob_baselines.geometric import GeometricController, GeometricIntegralController
from quad_dob_baselines.indi import NEURAL_FLY_INDI, IncrementalNDI
from quad_dob_baselines.l1 import NEURAL_FLY_L1, L1AdaptiveController
from quad_dob_baselines.neural_fly import NeuralFlyBaseline, NeuralFlyConstant
from quad_dob_baselines.observer import NonlinearDisturbanceObserver
from quad_dob_baselines.pid import CascadedPID
from quad_dob_baselines.raptor import RaptorController
from quad_dob_baselines.smc import SlidingModeController
from quad_dob_env.params import VehicleParams, get_vehicle
from quad_dob_env.validation import unknown_name_error

# Observer decay rates [1/s] of the "tuned" preset, the recommended base: chosen by
# `quad-dob tune` (training/tuning/tune.py), a grid of 1-40 /s on tuning seeds 100-109 of the v1
# wind scenarios, a force-and-torque step and a perturbed paper helix; the slowest within
# 2 % of the best. Time constants 25 ms (translation) and 0.2 s (rotation).
TUNED_OBSERVER_RATES = {"translational_rate": 40.0, "rotational_rate": 5.0}
# The geometric controller's gains tuned by the same procedure (coordinate descent from Lee
# 2010's on the same seeds and scenarios, the observer at the rates above; objective
# 0.0199 m -> 0.0087 m): kx x1.96, kR x2, kΩ x0.7, kv kept. Not the recommended base, which
# keeps the paper's gains: a baseline to measure residual policies against fairly.
TUNED_GEOMETRIC_GAINS = {"kx_per_mass": 31.36, "kv_per_mass": 5.6, "kR": 17.62,
                         "kOmega": 1.778}


OBSERVER_RATE_OPTIONS = ("translational_rate", "rotational_rate")


def _geometric_ndob(vehicle: VehicleParams, gains: str = "paper", **options: object
                    ) -> Controller:
    rates = {key: options.pop(key) for key in OBSERVER_RATE_OPTIONS if key in options}
    if gains == "paper" and rates:
        raise ValueError(f"geometric-ndob flies the paper's observer gains; observer rates "
                         f"({', '.join(rates)}) go to geometric-ndob:tuned")
    if gains == "paper":
        observer = NonlinearDisturbanceObserver()
    elif gains == "tuned":
        observer = NonlinearDisturbanceObserver.from_rates(
            vehicle=vehicle, **{**TUNED_OBSERVER_RATES, **rates})
    else:
        raise unknown_name_error("observer gains preset", gains, ["paper", "tuned"])
    controller = GeometricController(observer=observer, **options)
    if gains != "paper":
        controller.name = f"geometric-ndob:{gains}"
    return controller


def _named(controller: Controller, name: str) -> Controller:
    controller.name = name
    return controller


CONTROLLERS: dict[str, Callable[..., Controller]] = {
    "geometric": lambda vehicle, **options: GeometricController(**options),
    "geometric-ndob": _geometric_ndob,
    "geometric-ndob:tuned": lambda vehicle, **options: _geometric_ndob(vehicle, "tuned",
                                                                        **options),
    "geometric-ndob:gains-tuned": lambda vehicle, **options: _named(
        _geometric_ndob(vehicle, "tuned", **{**TUNED_GEOMETRIC_GAINS, **options}),
        "geometric-ndob:gains-tuned"),
    "geometric-integral": lambda vehicle, **options: GeometricIntegralController(**options),
    "indi": lambda vehicle, **options: IncrementalNDI(**options),
    "indi-outer": lambda vehicle, **options: _named(
        IncrementalNDI(**{**NEURAL_FLY_INDI, **options}), "indi-outer"),
    "l1": lambda vehicle, **options: L1AdaptiveController(**options),
    "l1-matched": lambda vehicle, **options: _named(
        L1AdaptiveController(**{**NEURAL_FLY_L1, **options}), "l1-matched"),
    "nf-constant": lambda vehicle, **options: NeuralFlyConstant(**options),
    "nf-baseline": lambda vehicle, **options: NeuralFlyBaseline(**options),
    "pid": lambda vehicle, **options: CascadedPID(**options),
    "smc": lambda vehicle, **options: SlidingModeController(**options),
    "raptor": lambda vehicle, **options: RaptorController(**options),
    "crazyflie-lee": lambda vehicle, **options: FirmwareLeeController(**options),
}


# the six classical names every benchmark's suite and tuning compare, and the laws
# Neural-Fly flew (v4's wind-tunnel counterparts, issue 55)
CLASSICAL_NAMES = ("geometric-ndob:tuned", "geometric-integral", "indi", "l1", "pid", "smc")
NEURAL_FLY_LAWS = ("nf-constant", "nf-baseline", "indi-outer", "l1-matched")


def controller_names() -> list[str]:
    """Every name ``make_controller`` takes: the built-in ones, then those installed
    packages register (``plugins.ENTRY_POINT_GROUP``); ``py:package.module:Name`` too."""
    return [*CONTROLLERS, *plugins.installed_controllers(CONTROLLERS)]


def is_controller_name(name: object) -> bool:
    """Whether ``make_controller`` knows ``name`` (without importing a ``py:`` module)."""
    return isinstance(name, str) and (name in CONTROLLERS or plugins.is_py_spec(name)
                                      or name in plugins.installed_controllers(CONTROLLERS))


def user_controller(name: str) -> tuple[plugins.ControllerFactory, Any] | None:
    """(factory, the object it came from) for a ``py:`` or entry-point name; None for a
    built-in one; a ValueError naming the valid ones for a name that is neither."""
    found = plugins.resolve(name, CONTROLLERS)
    if found is None and name not in CONTROLLERS:
        raise unknown_name_error("controller", name, [*controller_names(),
                                                      "py:package.module:Name"])
    return found


def make_controller(name: str, vehicle: VehicleParams | str = "paper",
                    benchmark: str = "v1", **options: object) -> Controller:
    """The named controller for ``vehicle`` with the gains its name means in ``benchmark``
    (``gain_sets``: v1's are the modules' defaults) and what it reads in that benchmark's
    loop (``BENCHMARK_INPUTS``: v4's INDI models its actuators); ``options`` override them.
    A user's controller (``py:package.module:Name`` or an installed entry point, ``plugins``) flies
    its own defaults in every benchmark."""
    params = get_vehicle(vehicle)
    user = user_controller(name)
    if user is not None:
        controller = plugins.built_controller(user[0], name, params, options)
        controller.gain_set = GainSet({}, None)
        return controller
    chosen = gain_set(name, benchmark, params)
    inputs = BENCHMARK_INPUTS.get((name, benchmark), {})
    controller = CONTROLLERS[name](params, **{**chosen.options, **inputs, **options})
    controller.gain_set = chosen
    return controller


__all__ = [
    "BENCHMARK_INPUTS",
    "CLASSICAL_NAMES",
    "CONTROLLERS",
    "GAIN_SETS",
    "MARGIN_LOSSES",
    "NEURAL_FLY_LAWS",
    "TUNED_GEOMETRIC_GAINS",
    "TUNED_OBSERVER_RATES",
    "CascadedPID",
    "Controller",
    "FirmwareLeeController",
    "FirmwareLeeGains",
    "GainSet",
    "GeometricController",
    "GeometricIntegralController",
    "IncrementalNDI",
    "L1AdaptiveController",
    "NeuralFlyBaseline",
    "NeuralFlyConstant",
    "NonlinearDisturbanceObserver",
    "RaptorController",
    "SlidingModeController",
    "controller_names",
    "gain_set",
    "is_controller_name",
    "make_controller",
    "plugins",
    "user_controller",
]
