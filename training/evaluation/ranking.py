"""One rule for "strongest" (issue 56): every row, learned or classical, ranks first by the
flights it lost (fewer first), then by its mean RMS position error after the settle time
(lower first); a row that scored no flight ranks after every row that scored one of as
many lost. Ties keep the order given.

``strongest(standings, benchmark)`` is the best of the classical names that benchmark
compares (``candidates``): the six classical names, and from v4 on the laws Neural-Fly
flew (``quad_dob_baselines.NEURAL_FLY_LAWS``). ``quad-dob evaluate``'s leaderboard, the
training log (``learning.baseline_evaluation``), ``benchmarks/residual_vs_strongest.py``
and ``benchmarks/suite_table.py --strongest`` all rank by it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import NamedTuple

from quad_dob_baselines import CLASSICAL_NAMES, NEURAL_FLY_LAWS
from quad_dob_env.benchmark import BENCHMARKS

# the first benchmark whose strongest includes the laws Neural-Fly flew (issue 55)
COUNTERPARTS_FROM = "v4"


class Standing(NamedTuple):
    """What a row is ranked by."""

    lost: float  # flights lost (or their share, where every row flew the same seeds)
    rms: float  # [m] mean RMS position error after the settle time; nan: none scored

    def key(self) -> tuple[int, float]:
        return self.lost, math.inf if math.isnan(self.rms) else self.rms


def beats(one: Standing, other: Standing) -> bool:
    """Whether ``one`` ranks strictly before ``other``."""
    return one.key() < other.key()


def ranked(standings: Mapping[str, Standing]) -> list[str]:
    """The names of ``standings``, best first (module docstring)."""
    return sorted(standings, key=lambda name: standings[name].key())


def candidates(benchmark: str) -> tuple[str, ...]:
    """The classical names ``benchmark``'s strongest is chosen from."""
    if benchmark not in BENCHMARKS:
        raise ValueError(f"unknown benchmark {benchmark!r}; valid: {', '.join(BENCHMARKS)}")
    later = BENCHMARKS.index(benchmark) >= BENCHMARKS.index(COUNTERPARTS_FROM)
    return (*CLASSICAL_NAMES, *(NEURAL_FLY_LAWS if later else ()))


def strongest(standings: Mapping[str, Standing], among: Iterable[str]) -> str:
    """The best of ``among`` in ``standings`` (each of them must be there)."""
    names = list(among)
    missing = [name for name in names if name not in standings]
    if missing:
        raise ValueError(f"the strongest is chosen among {', '.join(names)}; not flown: "
                         + ", ".join(missing))
    return ranked({name: standings[name] for name in names})[0]
