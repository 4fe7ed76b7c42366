"""Input checks shared by every layer: each failure names the field, the value and what is allowed.

This module imports nothing from the package, so every layer may use it.
"""

from __future__ import annotations

import difflib
import functools
import inspect
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

# Experiments removed from the code (issue 41), each named with the page that keeps its
# finding and the commands that reproduce it at the last commit that had it: a config or
# call that still names one is told where it went, not only that it is unknown
REMOVED_EXPERIMENTS_PAGE = "docs/research/removed-experiments.md"
# each removed experiment's name: what it was, the issue that removed it, and the last
# commit that holds it (where the page's commands reproduce its finding)
REMOVED_EXPERIMENTS: dict[str, tuple[str, int, str]] = {
    "termination_penalty": ("the training key termination_penalty", 41, "666bb22"),
    "tunnel-tracks": ("the scenario tunnel-tracks", 41, "666bb22"),
    "lookahead": ("the residual option lookahead", 42, "8a6fabb"),
    "residual_cutoff": ("the residual option residual_cutoff", 42, "8a6fabb"),
}


def unknown_name_error(kind: str, name: object, valid: Iterable[str]) -> ValueError:
    """A ValueError naming the unknown value, every valid one, and the closest match; a
    removed experiment's name (``REMOVED_EXPERIMENTS``) is also told the page that keeps
    its finding."""
    valid = list(valid)
    message = f"unknown {kind} {name!r}; valid: {', '.join(valid)}"
    if isinstance(name, str) and name in REMOVED_EXPERIMENTS:
        what, issue, commit = REMOVED_EXPERIMENTS[name]
        return ValueError(
            f"{what} was removed (issue {issue}); its finding and the commands that "
            f"reproduce it at commit {commit} are in {REMOVED_EXPERIMENTS_PAGE}. {message}")
    same_but_case = [v for v in valid if v.lower() == str(name).lower()]
    close = same_but_case or difflib.get_close_matches(str(name), valid, n=1)
    if close:
        message += f" (did you mean {close[0]!r}?)"
    return ValueError(message)


def keyword_names(*functions: Callable) -> list[str]:
    """The keyword arguments ``functions`` take by name, together (``self`` left out)."""
    names: dict[str, None] = {}
    for function in functions:
        for parameter in inspect.signature(function).parameters.values():
            if parameter.kind in (parameter.POSITIONAL_OR_KEYWORD, parameter.KEYWORD_ONLY) \
                    and parameter.name != "self":
                names[parameter.name] = None
    return list(names)


def checked_keywords(*forwards_to: Callable) -> Callable:
    """Decorate a function (or ``__init__``) so that a keyword it does not take, nor the
    functions it hands its ``**kwargs`` to (``forwards_to``), is a ValueError naming it,
    the valid names and the closest, where Python would raise a bare TypeError naming only
    the innermost function (``gym.make("QuadDOB/Hover-v1", action_mod=...)``)."""
    def decorate(function: Callable) -> Callable:
        owner = function.__qualname__.removesuffix(".__init__")
        valid = keyword_names(function, *forwards_to)

        @functools.wraps(function)
        def checked(*args: Any, **kwargs: Any) -> Any:
            for key in kwargs:
                if key not in valid:
                    raise unknown_name_error(f"keyword argument of {owner}", key, valid)
            return function(*args, **kwargs)
        return checked
    return decorate


def as_vector3(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A finite 3-vector, or a ValueError that names the field and what it got."""
    try:
        # a string or a flag is no number, though numpy would read "2" and True as ones
        if np.asarray(value).dtype.kind in "USb":
            raise ValueError
        vector = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite 3-vector of numbers, got {value!r}") from None
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise ValueError(f"{name} must be a finite 3-vector, got {value!r}")
    return vector


def as_finite(value: object, name: str, minimum: float | None = None,
              strictly: bool = False) -> float:
    """A finite float, at least (or above, if ``strictly``) ``minimum``; else ValueError.
    A string (``"2"``) or a bool is refused: Python's ``float`` would take either as a
    number, hiding a value that came through unparsed (the CLI parses its own)."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ValueError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not np.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if minimum is not None and (number < minimum or (strictly and number == minimum)):
        relation = ">" if strictly else ">="
        raise ValueError(f"{name} must be {relation} {minimum}, got {value!r}")
    return number
