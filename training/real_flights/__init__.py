"""Real flights other than Neural-Fly's, read from the user's own copy of a dataset (never
shipped, downloaded or committed): today the Crazyflie's on-board logs that Crazyswarm2's
experiments recorded (``IMRCLab/crazyswarm2-tools``; docs/research/crazyflie-sources.md).

- ``crazyflie_log``: the Crazyflie's uSD log format, read and written by this project's own
  code (the writer makes the logs the reader is tested on).
- ``crazyswarm2``: ``quad-dob real-flights crazyswarm2``, each log beside the simulator
  flying it (``quad_dob_env.crazyflie_loop``, ``crazyflie-lee``), both scored by
  ``wind_tunnel.flight_statistics.error_statistics`` over the log's own samples.

May import ``quad_dob_env`` and the parts of ``quad_dob_training`` below it (the order:
docs/design.md, "Layers"); not ``cli``.
"""

# the logs issue 59 compares: the one bare flight (178) and those with Crazyswarm2's payload
CRAZYSWARM2_LOGS = (178, 182, 183, 184, 201, 202, 203, 204, 205, 206)
