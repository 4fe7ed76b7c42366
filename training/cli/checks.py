"""The checks the ``quad-dob`` command line runs on what it is given, before any work: names,
``KEY=VALUE`` options, numbers in range, output folders and files that can be written. Each
failure is a ValueError (or argparse's own type error) naming the option and what it allows.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

# More timesteps than any run on record by five orders of magnitude: a larger --timesteps is
# a typo, and SB3 would only find out after building the env and the model.
MAX_TIMESTEPS = 10**11
MAX_SEED = 2**32 - 1  # numpy seeds the run's generators from it


def comma_list(text: str) -> list[str]:
    """``"pid, smc,"`` -> ``["pid", "smc"]``: a comma-separated option's names."""
    return [name.strip() for name in text.split(",") if name.strip()]


def key_values(pairs: list[str], option: str) -> dict[str, object]:
    """``["dt=0.005", "wind=moderate"]`` -> ``{"dt": 0.005, "wind": "moderate"}``: each
    value a number as Python reads one (``1e-3`` too, which YAML 1.1 leaves a string), else
    parsed as YAML (``true``/``false``, lists, mappings; anything else stays text), here, so
    the library is never handed an unparsed string for a number."""
    import yaml

    options: dict[str, object] = {}
    for pair in pairs:
        key, equals, text = pair.partition("=")
        key = key.strip()
        if not equals or not key.isidentifier():
            raise ValueError(f"{option} takes KEY=VALUE with KEY a name, such as dt=0.005, "
                             f"got {pair!r}")
        if key in options:
            raise ValueError(f"{option} {key} is given twice")
        try:
            options[key] = _parsed_number(text.strip()) if _is_number(text) else (
                yaml.safe_load(text) if text.strip() else "")
        except yaml.YAMLError:
            raise ValueError(f"{option} {pair!r}: the value is not a number, a word or a "
                             "YAML list or mapping") from None
    return options


def delay_grid(text: str) -> tuple[float, ...]:
    """``"0,0.01,0.02"`` -> increasing latencies >= 0 [s] (``margins.check_grid``), or
    argparse's error."""
    from quad_dob_training.evaluation.margins import check_grid

    try:
        return check_grid(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parsed_number(text: str) -> int | float:
    try:
        return int(text)
    except ValueError:
        return float(text)


def writable_folder(path: Path, option: str) -> None:
    """Refuse, before any work, an output folder that is a file or cannot be written:
    create it (its parents too) and a file in it, as the command will."""
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} {str(path)!r} is a file, not a folder: give a folder to "
                         "write into")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as error:
        raise ValueError(f"{option} {str(path)!r} cannot be written ({error.strerror}): give "
                         "a folder you may write into") from None


def writable_file(path: Path, option: str) -> None:
    """Refuse, before any work, an output file that is a folder or whose folder cannot be
    written."""
    if path.is_dir():
        raise ValueError(f"{option} {str(path)!r} is a folder: give a file name")
    writable_folder(path.parent if str(path.parent) else Path("."), f"{option}'s folder")
    if path.exists() and not os.access(path, os.W_OK):
        raise ValueError(f"{option} {str(path)!r} exists and cannot be overwritten")


def number_in(kind: type, low: float, high: float, what: str,
               strictly: bool = False) -> object:
    """An argparse type: a ``kind`` number in [low, high] (above ``low`` if ``strictly``)."""
    def parse(text: str) -> float | int:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}") from None
        if not (value > low if strictly else value >= low) or value > high:
            raise argparse.ArgumentTypeError(f"must be {'>' if strictly else '>='} {low:g} "
                                             f"and <= {high:g}, got {text}")
        return value
    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


positive_float = number_in(float, 0, 1e9, "a number", strictly=True)
positive_int = number_in(int, 1, MAX_TIMESTEPS, "a whole number")
seed_number = number_in(int, 0, MAX_SEED, "a whole number")


def tuning_seeds(text: str) -> tuple[int, ...]:
    """``quad-dob tune --seeds``: a count or range as for evaluate, none of them an
    evaluation seed (9001-9020: reported on, so never tuned on)."""
    from quad_dob_training.evaluation.evaluate import parse_seeds

    try:
        seeds = parse_seeds(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    held_out = sorted(set(seeds) & set(range(9001, 9021)))
    if held_out:
        raise argparse.ArgumentTypeError(f"seed {held_out[0]} is an evaluation seed "
                                         "(9001-9020): tune on others, such as 100-109")
    return tuple(seeds)
