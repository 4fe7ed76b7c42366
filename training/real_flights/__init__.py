"""Real flights other than Neural-Fly's, read from the user's own copy of a dataset (never
shipped, downloaded or committed): today the Crazyflie's on-board logs that Crazyswarm2's
experiments recorded (``IMRCLab/crazyswarm2-tools``; docs/research/crazyflie-sources.md).

- ``crazyflie_log``: the Crazyflie's uSD log format, read and written by this project's own
  code (the writer makes the logs the reader is tested on).

May import ``quad_dob_env`` and the parts of ``quad_dob_training`` below it (the order:
docs/design.md, "Layers"); not ``cli``.
"""
