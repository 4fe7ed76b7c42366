"""``quad-dob real-flights crazyswarm2``: Crazyswarm2's Crazyflie logs beside the simulator
flying the same flights, each side scored by the same code (``error_statistics``) over the
same window: the log's own sample times.

Per log (``logs/logN`` and ``info/infoN.yaml`` of the user's copy of
``IMRCLab/crazyswarm2-tools``; the reference ``info``'s ``trajectory`` from the user's copy
of Crazyswarm2's ``tune-lee`` trajectory files), the simulator flies:

- the vehicle ``crazyflie-2.1`` at the log's weight, its hover thrust over g
  (``quad_dob_env.crazyflie_loop``), less the payload where the weight says it carries one
  (the weight less the payload vehicle's own), which then hangs on a cable of the log's own
  measured length (0.5 m where it did not track the payload);
- the firmware's Lee law (``crazyflie-lee``) with the info file's gains and told mass;
- the loop as the firmware runs it (``crazyflie_loop.loop_options``), at 500 Hz;
- the reference the firmware flew: the trajectory file at the info file's time scale,
  started from the log's first setpoint, after ``LEAD_IN`` of hover.

Both sides' error is the on-board estimate less the setpoint (the log's ``stateEstimateZ``
and ``ctrltargetZ``; the simulator's estimate and reference), at the log's sample times,
gaps included. Seeds draw the sensors' noise; nothing here is tuned. Nothing of the logs is
written but summary statistics.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import yaml
from numpy.typing import NDArray

from quad_dob_baselines.crazyflie_lee import FirmwareLeeController, FirmwareLeeGains
from quad_dob_env.crazyflie_loop import (
    CABLE_LENGTH,
    CONTROL_PERIOD,
    LEAD_IN,
    PAYLOAD_MASS,
    PAYLOAD_VEHICLE_MASS,
    VEHICLE,
    loop_options,
    payload,
)
from quad_dob_env.loop_options import LoopOptions
from quad_dob_env.params import VEHICLES
from quad_dob_env.scenario import Scenario
from quad_dob_env.trajectories.polynomial import PiecewisePolynomial
from quad_dob_training.evaluation.console import text_table
from quad_dob_training.evaluation.statistics import (
    ErrorStatistics,
    bootstrap_mean,
    error_statistics,
)
from quad_dob_training.progress import Progress
from quad_dob_training.real_flights.crazyflie_log import read_log

GRAVITY = 9.81  # [m/s²] the firmware's GRAVITY_MAGNITUDE
HOVER_SPAN = 1.5  # [s] the log's end, hovering after the reference, where its weight is read
EVENT = "fixedFrequency"  # Crazyswarm2's logging event
# the pairs (same reference and time scale) whose payload change is compared, heavier less
# lighter: 182 carries 19 g by its weight, 201 5 g (their info files tell 32 and 41.9 g).
# No bare log flies a reference a payload log flies at its time scale (178 alone is bare)
PAYLOAD_PAIRS = ((182, 201),)
# the orderings the issue asks the simulator to keep: the figure-8 at time scales 2.0, 1.0
# and 0.8 with the payload (201, 202, 203)
TIME_SCALE_ORDER = (201, 202, 203)


@dataclass(frozen=True)
class Flight:
    """One Crazyswarm2 log, as much of it as the comparison reads: the info file's
    reference, time scale and gains; the log's sample times [s from its first record], the
    estimate and setpoint (T, 3) [m]; its weight [N]; the cable length [m] if it carries a
    payload (None otherwise)."""

    number: int
    trajectory: str
    time_scale: float
    gains: FirmwareLeeGains
    t: NDArray
    estimate: NDArray
    setpoint: NDArray
    weight: float
    cable_length: float | None

    @property
    def error(self) -> NDArray:
        return self.estimate - self.setpoint

    @property
    def payload_mass(self) -> float:
        """[kg] the weight less the payload vehicle's mass; 0 without a payload."""
        if self.cable_length is None:
            return 0.0
        return self.weight / GRAVITY - PAYLOAD_VEHICLE_MASS


def _vector(fields: dict[str, NDArray], group: str, names: str = "xyz") -> NDArray:
    """(T, 3) of ``group.x``, ``.y``, ``.z``; the firmware logs them as int16 mm."""
    return np.stack([fields[f"{group}.{name}"] for name in names], axis=1) / 1000.0


def read_flight(folder: Path, number: int) -> Flight:
    """Log ``number`` of the Crazyswarm2-tools copy at ``folder`` (``logs/`` and ``info/``)."""
    log_path, info_path = folder / "logs" / f"log{number}", folder / "info" / f"info{number}.yaml"
    for path, what in ((log_path, "log"), (info_path, "info file")):
        if not path.is_file():
            raise ValueError(f"no {what} {str(path)!r}: --logs must be your copy of "
                             "IMRCLab/crazyswarm2-tools, with logs/logN and info/infoN.yaml")
    info = yaml.safe_load(info_path.read_text())
    if not isinstance(info, dict) or "trajectory" not in info or "timescale" not in info:
        raise ValueError(f"{info_path}: an info file names its trajectory and timescale")
    fields = read_log(log_path).event(EVENT)
    needed = [f"{group}.{axis}" for group in ("stateEstimateZ", "ctrltargetZ") for axis in "xyz"]
    missing = [name for name in needed if name not in fields]
    if missing:
        raise ValueError(f"{log_path} logs no {', '.join(missing)}: the comparison needs the "
                         "estimate and the setpoint (stateEstimateZ, ctrltargetZ)")
    t = fields["timestamp"] - fields["timestamp"][0]
    # the firmware's thrust [N]; older builds spelt it thrustSi (log 178)
    names = [name for name in ("ctrlLee.thrustSI", "ctrlLee.thrustSi") if name in fields]
    if not names:
        raise ValueError(f"{log_path} logs no ctrlLee.thrustSI, from which its weight is read")
    thrust = fields[names[0]]
    weight = float(np.median(thrust[t >= t[-1] - HOVER_SPAN]))
    estimate = _vector(fields, "stateEstimateZ")
    # a payload where the log's weight says one hangs below (crazyflie_loop), on the cable
    # the log measures where it tracked the payload (log 183's fields are all zero)
    cable_length = None
    if weight / GRAVITY >= PAYLOAD_VEHICLE_MASS + PAYLOAD_MASS / 2:
        cable_length = CABLE_LENGTH
        if "stateEstimateZ.px" in fields:
            payload_position = _vector(fields, "stateEstimateZ", ("px", "py", "pz"))
            tracked = np.any(payload_position != 0.0, axis=1)
            if tracked.any():
                cable_length = float(np.median(np.linalg.norm(
                    payload_position[tracked] - estimate[tracked], axis=1)))
    return Flight(number=number, trajectory=str(info["trajectory"]),
                  time_scale=float(info["timescale"]),
                  gains=FirmwareLeeGains.from_parameters(info), t=t, estimate=estimate,
                  setpoint=_vector(fields, "ctrltargetZ"), weight=weight,
                  cable_length=cable_length)


def flight_scenario(flight: Flight, trajectories: Path) -> Scenario:
    """The simulated counterpart of ``flight`` (module docstring)."""
    path = trajectories / flight.trajectory
    if not path.is_file():
        raise ValueError(f"no trajectory {str(path)!r}: --trajectories must be your copy of "
                         "Crazyswarm2's tune-lee crazyflie_examples/crazyflie_examples/data")
    payload_mass = flight.payload_mass
    vehicle = replace(VEHICLES[VEHICLE], mass=flight.weight / GRAVITY - payload_mass)
    start = flight.setpoint[0]
    # a relative start shifts the file's path so that it begins at the setpoint it starts
    # from (crazyflie-firmware planner.c, plan_start_trajectory: shift = setpoint - p(0))
    unshifted = PiecewisePolynomial.from_csv(path, flight.time_scale)
    beginning = unshifted.position_derivatives(np.zeros(1))[0, 0]
    reference = PiecewisePolynomial.from_csv(path, flight.time_scale,
                                             offset=start - beginning, start_time=LEAD_IN)
    return Scenario(
        name=f"crazyswarm2-log{flight.number}", vehicle=vehicle, trajectory=reference,
        duration=LEAD_IN + float(flight.t[-1]) + 2 * CONTROL_PERIOD,
        disturbance=(None if flight.cable_length is None
                     else payload(payload_mass, flight.cable_length, vehicle.gravity)),
        initial_position=tuple(float(value) for value in start), dt=CONTROL_PERIOD,
        loop=LoopOptions(**loop_options()), settle_time=LEAD_IN,
        description=f"Crazyswarm2 log {flight.number}: {flight.trajectory} at time scale "
                    f"{flight.time_scale:g}")


@dataclass(frozen=True)
class SimulatedFlights:
    """The simulated side of one log: each seed's error at the log's sample times (None for
    a seed whose vehicle was lost before the window ended)."""

    errors: tuple[NDArray | None, ...]
    lost: int


def fly(flight: Flight, scenario: Scenario, seeds: Sequence[int]) -> SimulatedFlights:
    """One vehicle per seed in one vector env, flown by the firmware's law with the log's
    gains; the estimate less the reference kept at the log's sample times."""
    from quad_dob_composition import make_vector_env

    n = len(seeds)
    env = make_vector_env(n, scenario, base_controller=FirmwareLeeController(flight.gains))
    _, info = env.reset(seed=[int(seed) for seed in seeds])
    rows = np.rint((LEAD_IN + flight.t) / CONTROL_PERIOD).astype(int)
    errors = np.full((rows[-1] + 1, n, 3), np.nan)
    flying = np.ones(n, dtype=bool)
    actions = np.zeros((n, 4))  # a residual of zero: the firmware's law alone
    for step in range(rows[-1] + 1):
        errors[step, flying] = (info["estimate"]["position"]
                                - info["reference_position"])[flying]
        if step == rows[-1]:
            break
        _, _, terminated, truncated, info = env.step(actions)
        flying &= ~(np.asarray(terminated) | np.asarray(truncated))
    env.close()
    kept = errors[rows]  # (T, n, 3)
    per_seed = tuple(None if np.isnan(kept[:, i]).any() else kept[:, i] for i in range(n))
    return SimulatedFlights(errors=per_seed, lost=sum(error is None for error in per_seed))


@dataclass(frozen=True)
class LogComparison:
    """One log's two sides: the real statistics, each seed's simulated ones, and the sim's
    mean RMS and p95 with their 95 % intervals over the seeds."""

    number: int
    description: str
    reference: str  # the trajectory file's name and time scale, short
    payload: bool
    real: ErrorStatistics
    simulated: tuple[ErrorStatistics, ...]
    lost: int
    rms: tuple[float, float, float]  # mean, low, high [m]
    p95: tuple[float, float, float]
    # [m] RMS of the rebuilt reference less the log's setpoint at its samples: how well the
    # trajectory file, time scale, shift and start reproduce what the firmware flew
    reference_residual: float

    @property
    def rms_ratio(self) -> float:
        return self.rms[0] / self.real.rms_total

    @property
    def p95_ratio(self) -> float:
        return self.p95[0] / self.real.p95


def compare(flight: Flight, trajectories: Path, seeds: Sequence[int]) -> LogComparison:
    """``flight`` flown in simulation once per seed, both sides scored alike."""
    scenario = flight_scenario(flight, trajectories)
    simulated = fly(flight, scenario, seeds)
    statistics = tuple(error_statistics(error) for error in simulated.errors
                       if error is not None)
    if not statistics:
        raise ValueError(f"log {flight.number}: every simulated flight was lost (see its "
                         "info file's gains and the loop in quad_dob_env.crazyflie_loop)")
    rebuilt = scenario.trajectory.position_derivatives(LEAD_IN + flight.t)[0]
    residual = float(np.sqrt(np.mean(np.sum((rebuilt - flight.setpoint) ** 2, axis=1))))
    rms = tuple(bootstrap_mean([s.rms_total for s in statistics]))
    p95 = tuple(bootstrap_mean([s.p95 for s in statistics]))
    return LogComparison(number=flight.number, description=scenario.description,
                         reference=f"{Path(flight.trajectory).stem} x{flight.time_scale:g}",
                         payload=flight.cable_length is not None,
                         real=error_statistics(flight.error), simulated=statistics,
                         lost=simulated.lost, rms=rms, p95=p95, reference_residual=residual)


def ordering_kept(comparisons: dict[int, LogComparison], order: Sequence[int]) -> bool | None:
    """Whether the simulated RMS orders the logs ``order`` as the real one does (None when
    one of them was not flown)."""
    if any(number not in comparisons for number in order):
        return None
    real = np.argsort([comparisons[n].real.rms_total for n in order])
    simulated = np.argsort([comparisons[n].rms[0] for n in order])
    return bool(np.array_equal(real, simulated))


def _millimetres(value: float) -> str:
    return f"{1000 * value:.1f}"


def table(comparisons: Sequence[LogComparison]) -> str:
    """The side-by-side table, in mm: sim mean [95 % CI over the seeds], real, ratio; RMS
    and p95."""
    rows = []
    for c in comparisons:
        rows.append([
            str(c.number), c.reference, "yes" if c.payload else "no",
            f"{_millimetres(c.rms[0])} [{_millimetres(c.rms[1])}, {_millimetres(c.rms[2])}]",
            _millimetres(c.real.rms_total), f"{c.rms_ratio:.2f}",
            f"{_millimetres(c.p95[0])} [{_millimetres(c.p95[1])}, {_millimetres(c.p95[2])}]",
            _millimetres(c.real.p95), f"{c.p95_ratio:.2f}", str(c.lost)])
    return text_table(["log", "reference", "payload", "sim RMS", "real RMS", "ratio",
                       "sim p95", "real p95", "ratio", "lost"], rows)


def axis_table(comparisons: Sequence[LogComparison]) -> str:
    """Per-axis RMS [mm], sim (mean over seeds) and real, and the max of |e|."""
    rows = []
    for c in comparisons:
        sim = np.mean([[s.rms.x, s.rms.y, s.rms.z] for s in c.simulated], axis=0)
        real = (c.real.rms.x, c.real.rms.y, c.real.rms.z)
        rows.append([str(c.number), *(f"{_millimetres(s)} / {_millimetres(r)}"
                                      for s, r in zip(sim, real, strict=True)),
                     f"{_millimetres(np.mean([s.max for s in c.simulated]))} / "
                     f"{_millimetres(c.real.max)}"])
    return text_table(["log", "x sim / real", "y sim / real", "z sim / real",
                       "max sim / real"], rows)


def main(logs: Path, trajectories: Path, numbers: Sequence[int], seeds: Sequence[int],
         out: Path) -> int:
    """Compare each of ``numbers``; print the tables and write ``crazyswarm2.json``."""
    comparisons: dict[int, LogComparison] = {}
    with Progress("logs", len(numbers)) as progress:
        for number in numbers:
            progress.start(f"log {number}")
            comparisons[number] = compare(read_flight(logs, number), trajectories, seeds)
            progress.done(f"sim RMS {_millimetres(comparisons[number].rms[0])} mm")
    flown = [comparisons[n] for n in numbers]
    print(table(flown))
    print()
    print(axis_table(flown))
    summary = {"seeds": list(seeds), "logs": {}, "payload_changes": {}, "orderings": {}}
    for c in flown:
        summary["logs"][str(c.number)] = {
            "description": c.description, "payload": c.payload, "lost": c.lost,
            "real": asdict(c.real), "simulated": [asdict(s) for s in c.simulated],
            "sim_rms": c.rms, "sim_p95": c.p95, "rms_ratio": c.rms_ratio,
            "p95_ratio": c.p95_ratio, "reference_residual": c.reference_residual}
    print()
    print("the rebuilt reference against each log's setpoint, RMS [mm]: " + ", ".join(
        f"{c.number} {_millimetres(c.reference_residual)}" for c in flown))
    for heavier, lighter in PAYLOAD_PAIRS:
        if heavier in comparisons and lighter in comparisons:
            real = comparisons[heavier].real.rms_total - comparisons[lighter].real.rms_total
            sim = comparisons[heavier].rms[0] - comparisons[lighter].rms[0]
            summary["payload_changes"][f"{heavier}-{lighter}"] = {"real": real, "sim": sim}
            print(f"RMS of log {heavier} (heavier payload) less log {lighter}: sim "
                  f"{_millimetres(sim)} mm, real {_millimetres(real)} mm")
    kept = ordering_kept(comparisons, TIME_SCALE_ORDER)
    summary["orderings"]["time_scale"] = kept
    if kept is not None:
        print(f"time-scale ordering of logs {TIME_SCALE_ORDER}: "
              f"{'kept' if kept else 'not kept'}")
    out.mkdir(parents=True, exist_ok=True)
    (out / "crazyswarm2.json").write_text(json.dumps(summary, indent=1,
                                                     default=_json_default) + "\n")
    print(f"wrote {out / 'crazyswarm2.json'}")
    return 0


def _json_default(value: object) -> object:
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON: {type(value).__name__}")
