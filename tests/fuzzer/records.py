"""What happened, as records: ``Failure`` (one broken rule, with what reproduces it),
``Outcome`` (one configuration: built, refused or failed, and the figures of its flight;
JSON both ways, as a child process hands it back) and ``FuzzReport`` (a run of many: the
totals, the failures in classes, and ``summary``, the text a run prints).
"""

from __future__ import annotations

import collections
import dataclasses
from dataclasses import dataclass, field
from typing import Any

from .draw import MODES, short_config


@dataclass
class Failure:
    category: str
    index: int
    fuzz_seed: int
    message: str  # the traceback's last line, or what was wrong
    where: str = ""  # the innermost frame in the repository: file:line in function
    phase: str = ""
    config: dict[str, Any] = field(default_factory=dict)
    traceback: str = ""

    @property
    def key(self) -> tuple[str, str, str]:
        """What makes two failures the same: category, exception type, place."""
        kind = self.message.split(":")[0] if self.category.startswith("exception") else ""
        return (self.category, kind, self.where)

    def describe(self) -> str:
        return (f"[{self.category}] config {self.index} (seed {self.fuzz_seed}, phase "
                f"{self.phase}): {self.message}" + (f"\n    at {self.where}" if self.where
                                                     else "")
                + f"\n    repro: python tests/fuzzer --seed {self.fuzz_seed} "
                  f"--only {self.index}\n    config: {short_config(self.config)}")


@dataclass
class Outcome:
    index: int
    status: str = "built"  # built | refused | upstream | failed
    mode: str = ""
    built: bool = False  # the env was made (whatever happened next)
    refusal: str = ""
    failures: list[Failure] = field(default_factory=list)
    reasons: collections.Counter = field(default_factory=collections.Counter)
    step_calls: int = 0
    vehicle_steps: int = 0
    actions_refused: int = 0
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    wall: float = 0.0
    isolated: bool = False

    def to_json(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["reasons"] = dict(self.reasons)
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Outcome:
        data = dict(data)
        data["reasons"] = collections.Counter(data["reasons"])
        data["failures"] = [Failure(**f) for f in data["failures"]]
        return cls(**data)


@dataclass
class FuzzReport:
    seed: int
    configs: int = 0
    built: collections.Counter = field(default_factory=collections.Counter)  # by mode
    refused: int = 0
    upstream: int = 0
    failures: list[Failure] = field(default_factory=list)
    reasons: collections.Counter = field(default_factory=collections.Counter)
    step_calls: int = 0
    vehicle_steps: int = 0
    actions_refused: int = 0
    isolated: int = 0
    refusals: collections.Counter = field(default_factory=collections.Counter)
    accepted_invalid: collections.Counter = field(default_factory=collections.Counter)
    notes: collections.Counter = field(default_factory=collections.Counter)
    warnings: collections.Counter = field(default_factory=collections.Counter)
    slowest: list[tuple[float, int]] = field(default_factory=list)
    wall: float = 0.0

    def add(self, outcome: Outcome, config: dict[str, Any]) -> None:
        self.configs += 1
        if outcome.status == "refused":
            self.refused += 1
            self.refusals[_refusal_kind(outcome.refusal)] += 1
        elif outcome.status == "upstream":
            self.upstream += 1
        if outcome.built:
            self.built[outcome.mode] += 1
            if outcome.status == "built" and config["invalid"]:
                self.accepted_invalid.update(config["invalid"])
        self.failures += outcome.failures
        self.reasons.update(outcome.reasons)
        self.step_calls += outcome.step_calls
        self.vehicle_steps += outcome.vehicle_steps
        self.actions_refused += outcome.actions_refused
        self.isolated += outcome.isolated
        self.notes.update(outcome.notes)
        self.warnings.update(outcome.warnings)
        self.slowest = sorted([*self.slowest, (outcome.wall, outcome.index)], reverse=True)[:5]

    @property
    def failure_classes(self) -> dict[tuple[str, str, str], list[Failure]]:
        classes: dict[tuple[str, str, str], list[Failure]] = {}
        for failure in self.failures:
            classes.setdefault(failure.key, []).append(failure)
        return classes

    def failed_configs(self) -> int:
        return len({f.index for f in self.failures})

    def summary(self, refusals: int = 12) -> str:
        by_category = collections.Counter(f.category for f in self.failures)
        lines = [
            f"configurations tried: {self.configs} (seed {self.seed})",
            f"built: {sum(self.built.values())} ("
            + ", ".join(f"{m} {self.built[m]}" for m in MODES) + ")",
            f"refused with a clear error: {self.refused}",
            f"refused by Gymnasium for its own arguments: {self.upstream}",
            f"failed: {self.failed_configs()} configurations, {len(self.failures)} failures "
            f"in {len(self.failure_classes)} classes: {dict(by_category.most_common())}",
            f"  of which an uncaught exception: "
            f"{sum(n for c, n in by_category.items() if c.startswith('exception'))}, "
            f"a non-finite value: {sum(n for c, n in by_category.items() if 'non_finite' in c)}",
            f"episodes ended: {sum(self.reasons.values())} {dict(self.reasons.most_common())}",
            f"steps flown: {self.step_calls:,} step calls, {self.vehicle_steps:,} vehicle-steps; "
            f"invalid actions refused with ValueError: {self.actions_refused}",
            f"huge requests run in a child process: {self.isolated}",
            f"wall time: {self.wall:.1f} s ({self.wall / max(self.configs, 1):.3f} s per "
            f"configuration; slowest: "
            + ", ".join(f"#{i} {t:.1f} s" for t, i in self.slowest) + ")",
        ]
        if self.refusals:
            lines.append("most common refusals:")
            lines += [f"  {n:4d}  {kind}" for kind, n in self.refusals.most_common(refusals)]
        if self.accepted_invalid:
            lines.append("built although an option was drawn invalid (check these are "
                         f"meant to pass): {dict(self.accepted_invalid.most_common())}")
        if self.notes:
            lines.append(f"notes: {dict(self.notes.most_common())}")
        if self.warnings:
            lines.append("warnings:")
            lines += [f"  {n:4d}  {w}" for w, n in self.warnings.most_common(10)]
        for key, failures in self.failure_classes.items():
            lines.append(f"FAILURE CLASS {key[0]} ({len(failures)}x): "
                         + failures[0].describe())
        return "\n".join(lines)


def _refusal_kind(message: str) -> str:
    """A refusal's message without its values, to count kinds of refusal."""
    text = message.splitlines()[0] if message else ""
    for stop in (", got", "; valid", " would take", ": needs", " must be"):
        if stop in text:
            cut = text.index(stop)
            keep = {" must be": 40, " would take": 12}.get(stop, 0)
            return text[:cut + keep]
    return text[:90]
