"""Neural-Fly's wind tunnel: the figure-8 scenarios flown in it, and the tunnel's wind (a
steady mean carrying Dryden turbulence in proportion). Imports what ``scenarios`` imports,
never ``scenarios``."""

from __future__ import annotations

import math
from typing import Any

from quad_dob_env.benchmark import REAL_LOOP_BENCHMARKS
from quad_dob_env.benchmark_v3 import REAL_LOOPS
from quad_dob_env.disturbances import Constant, Disturbance, Dryden
from quad_dob_env.loop_options import LoopOptions
from quad_dob_env.params import VehicleParams, get_vehicle
from quad_dob_env.scenario import Scenario
from quad_dob_env.trajectories import Harmonic, RampedStart
from quad_dob_env.validation import as_finite

# Neural-Fly's wind-tunnel experiment (O'Connell et al., Science Robotics 2022, and the
# README of aerorobotics/neural-fly): a vertical figure-8 along the wind, x = 1.25 sin t,
# z = 2.15 + 0.75 sin 2t (their logs' centre height), 6.28 s a lap, heading fixed, in a
# steady wind along -x.
FIGURE8_WINDS = (0.0, 4.2, 8.5, 12.1)  # [m/s], the fan array's 0, 35, 70 and 100 % duty
FIGURE8_HEIGHT = 2.15
# The tunnel's turbulence: no figure is published for Caltech's fan-array tunnel; fan arrays
# are more turbulent than closed tunnels (Dougherty 2022, as cited by Stefan-Zavala et al.
# 2024). Our assumption: 5 % of the mean wind (σ_u / U), MIL-F-8785C Dryden spectra.
FIGURE8_TURBULENCE_INTENSITY = 0.05
# Neural-Fly's reference starts from rest: in all 30 of their wind-tunnel logs the figure-8's
# phase rate grows linearly from 0, 0.0796 t + 0.005 rad/s (median over the logs, fitted
# 1-11 s; spread between logs 0.011 rad/s), to 1 rad/s at 12.5 s, and holds: 1 / (4π) rad/s²
# for 4π s, one lap (aerorobotics/neural-fly, data/experiment, read for this figure alone).
NEURAL_FLY_RAMP = 4 * math.pi  # [s]
# Neural-Fly's position loop runs at 50 Hz. v1 and v2 fly the figure-8s at 100 Hz, because
# their latencies are resolved on the control grid (quad_dob_env.sensing.stage): at 50 Hz the
# mocap's 10 ms would become 20 ms. v3 flies 50 Hz with the pose's latency on the inner
# loop's tick grid, where 10 ms stays 10 ms.


def tunnel_wind(speed: float, intensity: float, height: float, direction: float) -> Disturbance:
    """A steady wind of ``speed`` m/s along ``direction`` [rad from +x] carrying
    ``intensity`` σ_u / U of Dryden turbulence."""
    if speed == 0:
        return Constant(wind=(0.0, 0.0, 0.0))
    if intensity == 0:
        # rounded so that a wind along an axis has no 1e-16 across it (sin π)
        return Constant(wind=(round(speed * math.cos(direction), 12),
                              round(speed * math.sin(direction), 12), 0.0))
    # W20 for σ_u: Dryden's own σ_u per unit W20 at this height (MIL-F-8785C, in Dryden)
    sigma_u_per_w20 = float(Dryden(wind_speed_6m=1.0, altitude=height).sigmas[0])
    return Dryden(wind_speed_6m=intensity * speed / sigma_u_per_w20, altitude=height,
                  direction=direction, mean_wind_speed=speed)


def figure8_wind(*, wind_speed: float, vehicle: str | VehicleParams = "neural-fly",
                 turbulence_intensity: float | None = None, benchmark: str = "v1",
                 reference_ramp: float | None = None, **fields: Any) -> Scenario:
    """The figure-8 at ``wind_speed``. Under ``benchmark="v3"`` or ``"v4"`` it flies
    Neural-Fly's 50 Hz outer loop and the tunnel turbulence v3 sources (``benchmark_v3``),
    its sensing and drag as the benchmark sets them; v1 and v2 fly 100 Hz,
    ``FIGURE8_TURBULENCE_INTENSITY`` and mocap sensing, drag and a motor lag pinned, as they
    always have. ``reference_ramp`` [s]: the reference starts from rest, its phase rate
    growing linearly to 1 rad/s over this long (``RampedStart``); 0 flies at speed from the
    start; None, the benchmark's: Neural-Fly's ``NEURAL_FLY_RAMP`` (4π s) in v4, 0 in
    v1-v3. ``fields`` are the scenario's (``make_scenario``'s options), laid over these."""
    params = get_vehicle(vehicle)
    v3 = benchmark in REAL_LOOP_BENCHMARKS
    if reference_ramp is None:
        reference_ramp = NEURAL_FLY_RAMP if benchmark == "v4" else 0.0
    real = REAL_LOOPS.get(params.name) if v3 else None
    if turbulence_intensity is None:
        turbulence_intensity = (real.tunnel_turbulence_intensity if real is not None
                                else FIGURE8_TURBULENCE_INTENSITY)
    speed = as_finite(wind_speed, "wind_speed", 0.0)
    intensity = as_finite(turbulence_intensity, "turbulence_intensity", 0.0)
    ramp = as_finite(reference_ramp, "reference_ramp", 0.0)
    figure8 = Harmonic(offset=(0.0, 0.0, FIGURE8_HEIGHT),
                       terms=[(0, 1.25, 1.0, 0.0), (2, 0.75, 2.0, 0.0)])
    if ramp > 0:
        figure8 = RampedStart(figure8, ramp)
    start = figure8.evaluate(0.0)
    # the mean wind and the turbulence it carries past
    disturbance = tunnel_wind(speed, intensity, FIGURE8_HEIGHT, math.pi)
    loop = (LoopOptions(benchmark=benchmark) if v3 else
            LoopOptions(benchmark=benchmark, drag=True, motor_lag=True, sensing="mocap"))
    return Scenario(**dict(
        name=f"figure8-wind-{speed:g}", vehicle=params, trajectory=figure8,
        duration=30.0, disturbance=disturbance, loop=loop,
        floor_height=0.0, initial_position=tuple(start.position[0]),
        initial_velocity=tuple(start.velocity[0]), settle_time=5.0,
        dt=1.0 / real.figure8_control_rate if real is not None else 0.01,
        description=f"Neural-Fly's wind-tunnel figure-8: x = 1.25 sin t, z = "
                    f"{FIGURE8_HEIGHT:g} + 0.75 sin 2t, heading fixed, {speed:g} m/s of wind "
                    f"along -x with {100 * intensity:g} % turbulence; mocap sensing; scored "
                    "after 5 s, as Neural-Fly; drag, motor lag, physical rotors"
                    + (f"; the reference starts from rest, at speed after {ramp:.2f} s"
                       if ramp > 0 else "")) | fields)
