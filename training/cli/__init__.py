"""The ``quad-dob`` command line (``quad-dob = quad_dob_training.cli:main``).

- ``commands``: the parser and every subcommand's entry (``list``, ``paper``, ``train``,
  ``evaluate``, ``leaderboard``, ``tune``, ``check-controller``, ``replay``, ``sweep``,
  ``hyperparams``, ``wind-tunnel``), each importing its work only when run.
- ``checks``: the checks on what the command line is given, before any work starts.
- ``listing``: what ``quad-dob list`` prints (every name, every preset number's source).
- ``replay``: episodes rendered to GIF/MP4, side by side (``quad-dob replay``).

May import every other part of ``quad_dob_training``; nothing imports it but the entry point
and ``wind_tunnel.tool``, whose ``quad-dob wind-tunnel`` parser uses ``checks``.
"""

from quad_dob_training.cli.commands import build_parser, main

__all__ = ["build_parser", "main"]
