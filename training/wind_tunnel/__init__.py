"""The wind-tunnel check: simulated figure-8 flights beside Neural-Fly's real ones.

- ``published``: Neural-Fly's published table (RMS error per controller and wind speed),
  the counterparts and the side-by-side with its factor of 2.
- ``tool``: the work of ``quad-dob wind-tunnel`` (its parser: ``cli.commands``): both sides
  through one code path, from a Neural-Fly folder the user supplies (never shipped).
- ``flight_logs``: Neural-Fly's logs read as flights (the same records simulated flights
  give).
- ``flight_statistics``: the statistics both sides share: per-axis error, the z share, the
  vertical residual force and its fit, the error's harmonics and phases, its lap-periodic
  share, the command over hover and the share at an actuator limit.
- ``verdicts``: sim against real per statistic: within or outside the tolerance Benchmark
  v4's targets give, else the ratio.
- ``plots``: the tool's figures.
- ``drag_fit``: Benchmark v4's drag, fitted in the simulator's tilted equilibrium to the
  logs' mean fa_x (``python -m quad_dob_training.wind_tunnel.drag_fit``).
- ``ablation``: the command line the ablation scripts in ``benchmarks/`` share.

May import ``quad_dob_env``, ``quad_dob_composition``, ``quad_dob_baselines`` and the parts
of ``quad_dob_training`` below it (``rollout``, ``rl``, ``policies``, ``evaluation``; the
order: docs/design.md, "Layers"); not ``cli``.
"""

# what ``quad_dob_training.wind_tunnel`` held when it was one module (before 2026-12-05)
from quad_dob_training.wind_tunnel.published import (
    COUNTERPARTS,
    COUNTERPARTS_V4,
    FACTOR,
    NEURAL_FLY_RMS,
    WIND_SPEEDS,
    rms_by_wind,
    side_by_side,
)

__all__ = ["COUNTERPARTS", "COUNTERPARTS_V4", "FACTOR", "NEURAL_FLY_RMS", "WIND_SPEEDS",
           "rms_by_wind", "side_by_side"]
