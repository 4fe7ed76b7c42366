"""Shared fixtures; hypothesis profiles (CI keeps the suite short)."""

import importlib.util
import os
import sys
from pathlib import Path

import pytest
from hypothesis import settings

BENCHMARKS = Path(__file__).parents[1] / "benchmarks"

# CI draws the same examples every run (derandomize), so a failure there always reproduces
settings.register_profile("ci", max_examples=50, deadline=None, derandomize=True)
settings.register_profile("dev", max_examples=100, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


@pytest.fixture
def benchmark_script(monkeypatch):
    """A script of benchmarks/ by name, loaded as a module (its ``main`` not run)."""
    def load(name: str):
        spec = importlib.util.spec_from_file_location(f"_script_{name}",
                                                      BENCHMARKS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        monkeypatch.setitem(sys.modules, spec.name, module)  # its dataclasses look it up
        spec.loader.exec_module(module)
        return module
    return load
