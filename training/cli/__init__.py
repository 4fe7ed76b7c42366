"""The ``quad-dob`` command line (``quad-dob = quad_dob_training.cli:main``).

- ``commands``: the parser and every subcommand's entry (``list``, ``paper``, ``train``,
  ``evaluate``, ``leaderboard``, ``tune``, ``check-controller``, ``replay``, ``sweep``,
  ``hyperparams``, ``wind-tunnel``), each importing its work only when run.
- ``checks``: the checks on what the command line is given, before any work starts.
- ``listing``: what ``quad-dob list`` prints (every name, every preset number's source).
- ``replay``: episodes rendered to GIF/MP4, side by side (``quad-dob replay``).

The top of ``quad_dob_training``: may import every other part of it; nothing imports it but
the entry point.
"""

from quad_dob_training.cli.commands import build_parser, main

__all__ = ["build_parser", "main"]
