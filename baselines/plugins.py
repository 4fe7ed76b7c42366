"""A user's controller by name: ``py:package.module:Name``, or a name an installed package
registers in the ``quad_dob_env.controllers`` entry-point group.

What such a name may point at (the interface, ``docs/controllers.md``):

- a subclass of ``quad_dob_baselines.Controller``, built as ``Name(**gains)``; or
- a function ``name(vehicle: VehicleParams, **gains) -> Controller``, as the built-in
  ``CONTROLLERS`` are.

Either declares what ``quad-dob tune`` may search as an attribute: ``tunable_gains``, a
dict of gain name to its default (the descent's start), and optionally
``estimator_bandwidths``, those of its gains that are an estimator's bandwidth [rad/s], which
the tuning caps and breaks ties on as it does the observer's rates.

A package registers a controller in its ``pyproject.toml``::

    [project.entry-points."quad_dob_env.controllers"]
    my-pd = "my_package.control:MyPD"

after which ``make_controller("my-pd")`` and ``--policies my-pd`` find it. No entry point
can take a name that already means something (``RESERVED``: a built-in controller, the
shipped policy ``residual``, or any name with a colon, the form of ``py:``, ``ALGO:PATH``
and the presets): such an entry point is skipped with a warning.
"""

from __future__ import annotations

import importlib
import inspect
import math
import warnings
from collections.abc import Callable, Iterable
from importlib import metadata
from typing import Any

from quad_dob_baselines.base import Controller
from quad_dob_env.params import VehicleParams

ENTRY_POINT_GROUP = "quad_dob_env.controllers"
PY_PREFIX = "py:"
# names a policy spec already gives a meaning to, besides the built-in controllers
RESERVED_POLICY_NAMES = ("residual",)
# a ``Name(**gains)`` class or a ``name(vehicle, **gains)`` function
ControllerFactory = Callable[..., Controller]


def is_py_spec(name: str) -> bool:
    return isinstance(name, str) and name.startswith(PY_PREFIX)


def installed_controllers(builtin: Iterable[str]) -> dict[str, metadata.EntryPoint]:
    """The controllers installed packages register, by name; one that takes a ``builtin``
    name, ``residual`` or a name with a colon is left out with a warning naming its
    package."""
    reserved = {*builtin, *RESERVED_POLICY_NAMES}
    found: dict[str, metadata.EntryPoint] = {}
    for entry in metadata.entry_points(group=ENTRY_POINT_GROUP):
        if entry.name in reserved or ":" in entry.name:
            package = entry.dist.name if entry.dist is not None else "an installed package"
            warnings.warn(f"{package} registers a controller named {entry.name!r} "
                          f"({entry.value}); that name already means something here "
                          "(a built-in controller, the shipped policy, or a name:with colon), "
                          "which is kept: the entry point is skipped",
                          RuntimeWarning, stacklevel=3)
            continue
        found.setdefault(entry.name, entry)
    return found


def load_py_spec(spec: str) -> Any:
    """The object ``py:package.module:Name`` names, imported; a ValueError that says which
    part was wrong otherwise."""
    target = spec[len(PY_PREFIX):]
    module_name, colon, attribute = target.partition(":")
    if not colon or not module_name or not attribute:
        raise ValueError(f"{spec!r}: a user controller is named py:package.module:Name (the "
                         "module to import, a colon, the class or function in it)")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise ValueError(f"{spec!r}: cannot import module {module_name!r} ({error}); is its "
                         "package installed, or its folder on PYTHONPATH?") from None
    except Exception as error:  # the module's own code failed: a SyntaxError, a raise, ...
        raise ValueError(f"{spec!r}: importing module {module_name!r} failed: "
                         f"{type(error).__name__}: {error}") from error
    found: Any = module
    for part in attribute.split("."):
        if not hasattr(found, part):
            # what the module itself defines, not what it imports (np, Controller)
            own = sorted(name for name, value in vars(module).items()
                         if not name.startswith("_") and callable(value)
                         and getattr(value, "__module__", None) == module.__name__)
            raise ValueError(f"{spec!r}: module {module_name!r} has no {attribute!r}; it "
                             f"defines {', '.join(own) or 'no class or function'}")
        found = getattr(found, part)
    return found


def as_factory(found: Any, spec: str) -> ControllerFactory:
    """What ``make_controller`` calls, ``factory(vehicle, **gains)``, for the object a user
    name points at: a ``Controller`` subclass is called with the gains alone."""
    if inspect.isclass(found):
        if not issubclass(found, Controller):
            raise ValueError(f"{spec!r} names the class {found.__qualname__}, which does not "
                             "derive from quad_dob_baselines.Controller")
        return lambda vehicle, **gains: found(**gains)
    if callable(found):
        return found
    raise ValueError(f"{spec!r} names a {type(found).__name__}, not a Controller subclass or "
                     "a function (vehicle, **gains) -> Controller")


def resolve(spec: str, builtin: dict[str, ControllerFactory]
            ) -> tuple[ControllerFactory, Any] | None:
    """(factory, the object it came from) for a user name, or None when ``spec`` is not
    one (a ``builtin`` name, or an unknown one)."""
    if spec in builtin:
        return None
    if is_py_spec(spec):
        found = load_py_spec(spec)
    else:
        entry = installed_controllers(builtin).get(spec)
        if entry is None:
            return None
        try:
            found = entry.load()
        except Exception as error:  # whatever the package's import raises
            raise ValueError(f"controller {spec!r}, registered by "
                             f"{entry.dist.name if entry.dist else 'a package'} as "
                             f"{entry.value}, failed to load: {error}") from error
    return as_factory(found, spec), found


def declared_gains(found: Any, spec: str) -> tuple[dict[str, float], tuple[str, ...]]:
    """The ``tunable_gains`` (name -> default) and ``estimator_bandwidths`` a user
    controller declares, checked: names are strings, defaults finite and positive (the
    descent multiplies them), bandwidths among the gains."""
    gains = getattr(found, "tunable_gains", None) or {}
    if not isinstance(gains, dict):
        raise ValueError(f"{spec!r}: tunable_gains must be a dict of gain name to default, "
                         f"got {type(gains).__name__}")
    for key, value in gains.items():
        if not isinstance(key, str) or isinstance(value, bool) or \
                not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise ValueError(f"{spec!r}: tunable gain {key!r} must default to a finite number "
                             f"above 0 (the tuning searches it by factors), got {value!r}")
    bandwidths = tuple(getattr(found, "estimator_bandwidths", ()) or ())
    stray = [name for name in bandwidths if name not in gains]
    if stray:
        raise ValueError(f"{spec!r}: estimator_bandwidths names {stray[0]!r}, which is not "
                         f"among its tunable_gains ({', '.join(gains) or 'none'})")
    return {key: float(value) for key, value in gains.items()}, bandwidths


def built_controller(factory: ControllerFactory, spec: str, vehicle: VehicleParams,
                     options: dict[str, Any]) -> Controller:
    """``factory(vehicle, **options)``, checked to be a ``Controller``; an unknown gain is
    named with the declared ones (Python's TypeError names only the function)."""
    try:
        controller = factory(vehicle, **options)
    except TypeError as error:
        raise ValueError(f"{spec!r} cannot be built with gains {sorted(options)}: "
                         f"{error}") from error
    if not isinstance(controller, Controller):
        raise ValueError(f"{spec!r} built a {type(controller).__name__}, not a "
                         "quad_dob_baselines.Controller")
    if controller.name == Controller.name:  # the template's: name it by its spec
        controller.name = spec
    return controller
