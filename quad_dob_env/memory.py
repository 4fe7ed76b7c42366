"""A memory budget, checked before anything large is allocated.

Valid-looking options can ask for more memory than a machine has: a reference table
tabulated at ``dt = 1e-4`` for a pool of 240 references, a start spread of 10⁷ s, ten
million evaluation seeds. Each place that sizes an allocation from user input computes the
bytes first and calls ``check_memory``, so the request is refused at once, with its size,
the budget and the option to change, instead of a ``MemoryError`` minutes later (or the
machine swapping).

The budget is ``DEFAULT_MEMORY_BUDGET`` bytes unless the environment variable
``QUAD_DOB_MEMORY_BUDGET`` gives another (a whole number of bytes). It bounds one request,
not the process: several envs may each take up to it.

This module imports nothing from the package, so every layer may use it.
"""

from __future__ import annotations

import os

MEMORY_BUDGET_VARIABLE = "QUAD_DOB_MEMORY_BUDGET"
DEFAULT_MEMORY_BUDGET = 4 * 2**30  # 4 GiB: a sixth of the project's 24 GiB machines


def memory_budget() -> int:
    """The budget in bytes: ``QUAD_DOB_MEMORY_BUDGET`` if set, else the default."""
    text = os.environ.get(MEMORY_BUDGET_VARIABLE)
    if text is None or not text.strip():
        return DEFAULT_MEMORY_BUDGET
    try:
        budget = int(text.strip())
    except ValueError:
        raise ValueError(f"{MEMORY_BUDGET_VARIABLE}={text!r} is not a whole number of bytes "
                         f"(the default is {DEFAULT_MEMORY_BUDGET})") from None
    if budget < 1:
        raise ValueError(f"{MEMORY_BUDGET_VARIABLE}={text!r} must be at least 1 byte")
    return budget


def format_bytes(size: float) -> str:
    """``1536`` -> ``'1.5 KiB'``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(size) < 1024 or unit == "TiB":
            return f"{size:.0f} B" if unit == "B" else f"{size:.3g} {unit}"
        size /= 1024
    raise AssertionError("unreachable")


def check_memory(size: float, what: str, change: str) -> None:
    """Refuse, with a ValueError, a request of ``size`` bytes over the budget: ``what``
    names the allocation and the option values behind it, ``change`` what to change."""
    budget = memory_budget()
    if size > budget:
        raise ValueError(f"{what} would take {format_bytes(size)}, over the memory budget of "
                         f"{format_bytes(budget)}: {change}, or raise the budget with "
                         f"{MEMORY_BUDGET_VARIABLE}=BYTES")
