"""Shared fixtures; hypothesis profiles (CI keeps the suite short)."""

import os

from hypothesis import settings

# CI draws the same examples every run (derandomize), so a failure there always reproduces
settings.register_profile("ci", max_examples=50, deadline=None, derandomize=True)
settings.register_profile("dev", max_examples=100, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
