"""Flight logs, real and simulated, as one record: ``FlightLog``.

Neural-Fly's wind-tunnel experiments (O'Connell et al., Science Robotics 2022; the
``aerorobotics/neural-fly`` repository, ``data/experiment/custom_figure8_<METHOD>_<COND>.csv``)
are read by ``read_neural_fly`` / ``read_neural_fly_folder`` from a folder the user gives:
their data is for personal and educational use only, so the project never ships, fetches or
copies it. Their CSVs have a leading unnamed index column, then ``t``, then one column per
field, each vector cell a bracketed list (``"[x, y, z]"``, the 3x3 ``R`` as nested lists, a
scalar as a one-element list ``[T]``), 50 Hz for about 50 s. ``write_neural_fly`` writes
the same format (for synthetic test logs).

A simulated episode becomes a ``FlightLog`` through the env's ``info`` (``InfoRecorder`` for
a vector env, ``log_from_infos`` for a single env's steps), so that real and simulated
flights are scored by the same code (``quad_dob_training.wind_tunnel.flight_statistics``).
"""

from __future__ import annotations

import csv
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.params import NEURAL_FLY_MASS, VehicleParams

# the file names of Neural-Fly's wind-tunnel figure-8s: custom_figure8_<METHOD>_<COND>.csv
NEURAL_FLY_PATTERN = re.compile(r"^custom_figure8_(?P<method>.+)_(?P<condition>[^_]+)\.csv$")
# their README: the fan array's duty cycle -> wind speed [m/s]; 70p20sint is 8.5 + 2.4 sin t
# m/s, a wind no simulated scenario blows (None: no steady speed)
NEURAL_FLY_CONDITIONS: dict[str, float | None] = {
    "nowind": 0.0, "35wind": 4.2, "70wind": 8.5, "100wind": 12.1, "70p20sint": None}
# their methods -> the label of the published table (training.wind_tunnel.NEURAL_FLY_RMS)
NEURAL_FLY_METHODS = {"baseline": "nonlinear baseline", "indi": "INDI", "L1": "L1 adaptive",
                      "NF-C": "NF-C", "NF": "NF", "NF-T": "NF-T"}
# the columns a log needs, each with its width per sample; fa and pwm are optional
COLUMNS = {"t": 1, "p": 3, "p_d": 3, "v": 3, "v_d": 3, "R": 9, "T_sp": 1,
           "hover_throttle": 1}
OPTIONAL_COLUMNS = {"fa": 3, "pwm": 4}
# Neural-Fly's column order (q, w, q_sp are not read)
NEURAL_FLY_ORDER = ("t", "p", "p_d", "v", "v_d", "q", "R", "w", "T_sp", "q_sp",
                    "hover_throttle", "fa", "pwm")


@dataclass(frozen=True)
class FlightLog:
    """One flight, every array with a leading time axis of T samples.

    ``t`` [s]; ``p``, ``p_d`` [m] and ``v``, ``v_d`` [m/s] (T, 3), world frame, z up;
    ``R`` (T, 3, 3) body to world; ``T_sp`` the collective thrust setpoint, normalised
    (0..1), and ``hover_throttle`` the setpoint believed to hold the weight, (T,) each;
    optional ``fa`` (T, 3) [N], the residual force the log itself records, ``pwm``
    (T, 4), and ``at_limit`` (T,), 1 where the actuators were at a limit (a simulated
    log's ``info["actuator_saturated"]``; a real log's comes from its ``pwm``:
    ``flight_statistics.limit_samples``). ``wind_speed`` [m/s] is None for a wind without
    a steady speed;
    ``thrust_source`` says what ``T_sp`` and ``hover_throttle`` were made from."""

    t: NDArray
    p: NDArray
    p_d: NDArray
    v: NDArray
    v_d: NDArray
    R: NDArray
    T_sp: NDArray
    hover_throttle: NDArray
    fa: NDArray | None = None
    pwm: NDArray | None = None
    at_limit: NDArray | None = None
    method: str = ""
    condition: str = ""
    wind_speed: float | None = None
    mass: float = NEURAL_FLY_MASS  # [kg]
    source: str = ""
    thrust_source: str = "T_sp"
    crashed: bool = False

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or len(t) < 3:
            raise ValueError(f"FlightLog.t must be (T,) with T >= 3 samples, got shape {t.shape}")
        if not np.all(np.diff(t) > 0):
            raise ValueError(f"FlightLog.t must increase strictly ({self.source or 'a log'})")
        shapes = {"p": (3,), "p_d": (3,), "v": (3,), "v_d": (3,), "R": (3, 3), "T_sp": (),
                  "hover_throttle": (), "fa": (3,), "pwm": (4,), "at_limit": ()}
        for name, shape in shapes.items():
            value = getattr(self, name)
            if value is None:
                continue
            array = np.asarray(value, dtype=float)
            if array.shape != (len(t), *shape):
                raise ValueError(f"FlightLog.{name} must have shape {(len(t), *shape)} (T = "
                                 f"{len(t)} samples), got {array.shape}")
            if not np.all(np.isfinite(array)):
                raise ValueError(f"FlightLog.{name} holds a value that is not finite "
                                 f"({self.source or 'a log'})")
            object.__setattr__(self, name, array)
        object.__setattr__(self, "t", t)
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise ValueError(f"FlightLog.mass must be a positive number of kg, got {self.mass}")

    @property
    def dt(self) -> float:
        """[s] the median sample period."""
        return float(np.median(np.diff(self.t)))


def _cell(text: str, width: int, column: str, row: int, path: Path) -> list[float]:
    """One CSV cell: a number or a bracketed (nested) list of ``width`` numbers."""
    try:
        values = [float(part) for part in text.replace("[", " ").replace("]", " ").split(",")]
    except ValueError:
        raise ValueError(f"{path}: row {row}, column {column!r}: {text[:60]!r} is not a number "
                         "or a bracketed list of numbers") from None
    if len(values) != width:
        raise ValueError(f"{path}: row {row}, column {column!r} holds {len(values)} numbers; "
                         f"{column} has {width} per sample")
    return values


def parse_name(path: Path) -> tuple[str, str]:
    """(method, condition) from ``custom_figure8_<METHOD>_<COND>.csv``."""
    match = NEURAL_FLY_PATTERN.match(path.name)
    if match is None:
        raise ValueError(f"{path.name!r} is not named custom_figure8_<METHOD>_<COND>.csv, as "
                         "Neural-Fly's wind-tunnel experiments are")
    method, condition = match.group("method"), match.group("condition")
    if method not in NEURAL_FLY_METHODS:
        raise ValueError(f"{path.name}: unknown method {method!r}; Neural-Fly's are "
                         + ", ".join(NEURAL_FLY_METHODS))
    if condition not in NEURAL_FLY_CONDITIONS:
        raise ValueError(f"{path.name}: unknown condition {condition!r}; Neural-Fly's "
                         "wind-tunnel figure-8s fly " + ", ".join(NEURAL_FLY_CONDITIONS))
    return method, condition


def read_neural_fly(path: Path | str, mass: float = NEURAL_FLY_MASS) -> FlightLog:
    """One of Neural-Fly's experiment CSVs as a ``FlightLog`` (method, condition and wind
    speed from its name; ``mass`` [kg], their vehicle's by default)."""
    path = Path(path)
    method, condition = parse_name(path)
    with open(path, newline="") as file:
        rows = list(csv.reader(file))
    if not rows:
        raise ValueError(f"{path}: empty file; a Neural-Fly experiment CSV has a header row")
    header = [name.strip() for name in rows[0]]
    missing = [name for name in COLUMNS if name not in header]
    if missing:
        raise ValueError(f"{path}: missing column(s) {', '.join(missing)}; a Neural-Fly "
                         f"experiment CSV has {', '.join(COLUMNS)} (and optionally "
                         f"{', '.join(OPTIONAL_COLUMNS)})")
    if len(rows) < 4:
        raise ValueError(f"{path}: {len(rows) - 1} data rows; a log needs 3 or more")
    widths = {**COLUMNS, **{k: w for k, w in OPTIONAL_COLUMNS.items() if k in header}}
    data: dict[str, NDArray] = {}
    for name, width in widths.items():
        index = header.index(name)
        data[name] = np.array([_cell(row[index], width, name, k, path)
                               for k, row in enumerate(rows[1:], start=1)], dtype=float)
    return FlightLog(
        t=data["t"][:, 0], p=data["p"], p_d=data["p_d"], v=data["v"], v_d=data["v_d"],
        R=data["R"].reshape(-1, 3, 3), T_sp=data["T_sp"][:, 0],
        hover_throttle=data["hover_throttle"][:, 0], fa=data.get("fa"), pwm=data.get("pwm"),
        method=method, condition=condition, wind_speed=NEURAL_FLY_CONDITIONS[condition],
        mass=mass, source=str(path))


def read_neural_fly_folder(folder: Path | str, mass: float = NEURAL_FLY_MASS
                           ) -> list[FlightLog]:
    """Every ``custom_figure8_*.csv`` of ``folder`` (Neural-Fly's ``data/experiment``), in
    name order; other files are left alone."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"--neural-fly {str(folder)!r} is not a folder: give the folder that "
                         "holds Neural-Fly's custom_figure8_<METHOD>_<COND>.csv files "
                         "(their repository's data/experiment)")
    paths = sorted(folder.glob("custom_figure8_*.csv"))
    if not paths:
        raise ValueError(f"{folder} holds no custom_figure8_<METHOD>_<COND>.csv file: give "
                         "the folder of Neural-Fly's wind-tunnel experiments (their "
                         "repository's data/experiment)")
    return [read_neural_fly(path, mass) for path in paths]


def _text(values: NDArray) -> str:
    # repr of each float: the reader gets the same numbers back, bit for bit
    if values.ndim == 0:
        return repr(float(values))
    return "[" + ", ".join(_text(value) for value in values) + "]"


def write_neural_fly(log: FlightLog, path: Path | str,
                     extra: Mapping[str, NDArray] | None = None) -> Path:
    """``log`` as one of Neural-Fly's experiment CSVs (their column order; ``extra``
    columns, (T, ...) each, go where their order puts them, else last). For synthetic
    logs: their data is never written by the project."""
    path = Path(path)
    fields: dict[str, NDArray] = {"t": log.t, "p": log.p, "p_d": log.p_d, "v": log.v,
                                  "v_d": log.v_d, "R": log.R,
                                  "T_sp": log.T_sp[:, None],
                                  "hover_throttle": log.hover_throttle[:, None]}
    for name in ("fa", "pwm"):
        if getattr(log, name) is not None:
            fields[name] = getattr(log, name)
    fields.update({name: np.asarray(value, dtype=float) for name, value in (extra or {}).items()})
    order = [name for name in NEURAL_FLY_ORDER if name in fields]
    order += [name for name in fields if name not in order]
    with open(path, "w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["", *order])
        for k in range(len(log.t)):
            writer.writerow([k, *(_text(fields[name][k]) for name in order)])
    return path


def log_from_fields(fields: Mapping[str, NDArray], vehicle: VehicleParams,
                    **metadata: object) -> FlightLog:
    """A ``FlightLog`` from one vehicle's ``info`` fields stacked over its steps ((T, ...)
    each; ``rotation`` (T, 3, 3)).

    ``T_sp`` and ``hover_throttle`` are ``info["thrust_setpoint"]`` and
    ``info["hover_throttle"]`` where the env reports them. Otherwise a stand-in, labelled in
    ``thrust_source``: the commanded collective thrust (``base_thrust``, the base
    controller's command in a residual env's info; a policy's thrust residual is not in
    it) or else the applied thrust
    (``applied_thrust``), each over the vehicle's full thrust, with the hover throttle its
    weight over the same: ``T_sp / hover_throttle`` is then the command over the m g the
    controller believes in."""
    full = vehicle.max_total_thrust
    if "thrust_setpoint" in fields and "hover_throttle" in fields:
        setpoint, hover = fields["thrust_setpoint"], fields["hover_throttle"]
        source = "info thrust_setpoint / hover_throttle"
    else:
        key = "base_thrust" if "base_thrust" in fields else "applied_thrust"
        setpoint = np.asarray(fields[key], dtype=float) / full
        hover = np.full(len(setpoint), vehicle.mass * vehicle.gravity / full)
        source = (f"stand-in: info {key} / full thrust "
                  f"({'commanded' if key == 'base_thrust' else 'applied'}), hover m g / full")
    return FlightLog(
        t=fields["time"], p=fields["reference_position"] + fields["position_error"],
        p_d=fields["reference_position"],
        v=fields["reference_velocity"] + fields["velocity_error"],
        v_d=fields["reference_velocity"], R=fields["rotation"], T_sp=setpoint,
        hover_throttle=hover, at_limit=fields.get("actuator_saturated"), mass=vehicle.mass,
        thrust_source=source, **metadata)


# the info entries a log is made of (rotation: info["rotation"], else the estimate's)
INFO_FIELDS = ("time", "reference_position", "position_error", "reference_velocity",
               "velocity_error", "base_thrust", "applied_thrust", "thrust_setpoint",
               "hover_throttle", "actuator_saturated")


def _fields_of(info: Mapping) -> dict[str, NDArray]:
    """The entries of one ``info`` a log needs. ``info`` has no true attitude: the
    estimate the controller read stands in (mocap's, within milliradians)."""
    found = {name: info[name] for name in INFO_FIELDS if name in info}
    found["rotation"] = info["rotation"] if "rotation" in info else info["estimate"]["rotation"]
    return found


def log_from_infos(infos: Sequence[Mapping], vehicle: VehicleParams,
                   **metadata: object) -> FlightLog:
    """A single env's ``info`` at each step (the reset's first: the state each command was
    planned from, and that command) as a ``FlightLog``."""
    steps = [_fields_of(info) for info in infos]
    names = steps[0].keys()
    return log_from_fields({name: np.array([s[name] for s in steps], dtype=float)
                            for name in names}, vehicle, **metadata)


class InfoRecorder:
    """A vector env's ``info``, step by step, for N vehicles, each stopped at its episode's
    end: ``add`` the info a command was planned from before each step, ``ended`` after it."""

    def __init__(self, n: int) -> None:
        self.steps: list[dict[str, NDArray]] = []
        self.flying: list[NDArray] = []
        self.still = np.ones(n, dtype=bool)
        self.crashed = np.zeros(n, dtype=bool)

    def add(self, info: Mapping) -> None:
        self.steps.append({name: np.array(value, dtype=float)
                           for name, value in _fields_of(info).items()})
        self.flying.append(self.still.copy())

    def ended(self, terminated: NDArray, truncated: NDArray) -> bool:
        """Mark whose episode the last step ended; whether any vehicle still flies."""
        self.crashed |= self.still & np.asarray(terminated, dtype=bool)
        self.still &= ~(np.asarray(terminated, dtype=bool) | np.asarray(truncated, dtype=bool))
        return bool(self.still.any())

    def logs(self, vehicle: VehicleParams, sources: Sequence[str] | None = None,
             **metadata: object) -> list[FlightLog]:
        """One log per vehicle (``sources``: each one's ``source``, e.g. its seed)."""
        flying = np.array(self.flying)  # (steps, N)
        stacked = {name: np.array([step[name] for step in self.steps])  # (steps, N, ...)
                   for name in self.steps[0]}
        logs = []
        for i in range(flying.shape[1]):
            fields = {name: values[flying[:, i], i] for name, values in stacked.items()}
            logs.append(log_from_fields(fields, vehicle, crashed=bool(self.crashed[i]),
                                        source="" if sources is None else sources[i],
                                        **metadata))
        return logs
