"""``quad-dob real-flights crazyswarm2`` on a Crazyswarm2-tools folder this test writes (our
own log writer, an info file, a trajectory file): what it reads of a log, the simulated
counterpart it builds, and that both sides are scored by the one ``error_statistics``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from quad_dob_env.crazyflie_loop import (
    CABLE_LENGTH,
    CONTROL_PERIOD,
    LEAD_IN,
    PAYLOAD_VEHICLE_MASS,
)
from quad_dob_training.cli.commands import main as cli_main
from quad_dob_training.evaluation.statistics import error_statistics
from quad_dob_training.real_flights.crazyflie_log import EventType, write_log
from quad_dob_training.real_flights.crazyswarm2 import (
    GRAVITY,
    flight_scenario,
    main,
    read_flight,
)

INFO = """experiment: {number}
trajectory: step.csv
timescale: 2.0
Kpos_Px: 17.0
Kpos_Py: 17.0
Kpos_Pz: 17.0
Kpos_Ix: 0.0
Kpos_Iy: 0.0
Kpos_Iz: 10.0
Kpos_Dx: 7.0
Kpos_Dy: 7.0
Kpos_Dz: 7.0
KR_x: 0.009
KR_y: 0.009
KR_z: 0.009
KI_x: 0.05
KI_y: 0.05
KI_z: 0.05
Kw_x: 0.00125
Kw_y: 0.00125
Kw_z: 0.0025
mass: 0.032
"""
# one 1 s piece, 8th order: x from 0.2 to 0.3 m as 0.1 (3τ² - 2τ³) (at rest at both ends),
# y and z held at -0.1 and 1.5 m: an absolute file starting elsewhere than the log's first
# setpoint (0, 0, 1), which the relative start shifts it to
COEFFICIENTS = ([0.2, 0.0, 0.3, -0.2, 0, 0, 0, 0], [-0.1] + [0.0] * 7, [1.5] + [0.0] * 7,
                [0.0] * 8)
WEIGHT = 0.040 * GRAVITY  # [N] the hover thrust the log holds at its end: with a payload
BARE_WEIGHT = 0.030 * GRAVITY  # [N] a bare Crazyflie's


def write_folder(tmp_path, number, payload_offset=None, seconds=2.6, weight=WEIGHT):
    """logs/logN, info/infoN.yaml and trajectories/step.csv: a log at 250 Hz that follows the
    reference with a known error, its thrust the weight; the payload's fields if given."""
    (tmp_path / "logs").mkdir(exist_ok=True)
    (tmp_path / "info").mkdir(exist_ok=True)
    (tmp_path / "traj").mkdir(exist_ok=True)
    (tmp_path / "info" / f"info{number}.yaml").write_text(INFO.format(number=number))
    row = [1.0] + [c for axis in COEFFICIENTS for c in axis]
    (tmp_path / "traj" / "step.csv").write_text(
        "duration," + ",".join(f"c{k}" for k in range(32)) + "\n"
        + ",".join(str(value) for value in row) + "\n")
    variables = [(f"stateEstimateZ.{axis}", "h") for axis in "xyz"]
    variables += [(f"ctrltargetZ.{axis}", "h") for axis in "xyz"]
    variables += [("ctrlLee.thrustSI", "f")]
    if payload_offset is not None:
        variables += [(f"stateEstimateZ.p{axis}", "h") for axis in "xyz"]
    event = EventType(0xFFFF, "fixedFrequency", tuple(variables))
    times = np.arange(0.0, seconds, 0.004)
    records = []
    for k, t in enumerate(times):
        target = (0, 0, 1000)
        estimate = (3 * ((k % 5) - 2), -2, 1000 + (k % 3))  # a known error [mm]
        values = [*estimate, *target, weight]
        if payload_offset == "untracked":  # the firmware logs zeros without the marker
            values += [0, 0, 0]
        elif payload_offset is not None:
            values += [e + o for e, o in zip(estimate, payload_offset, strict=True)]
        records.append((0xFFFF, 10.0 + t, tuple(values)))
    write_log(tmp_path / "logs" / f"log{number}", [event], records)
    return times


def test_a_log_is_read_as_the_comparison_needs_it(tmp_path):
    times = write_folder(tmp_path, 7, payload_offset=(0, 300, -400))
    flight = read_flight(tmp_path, 7)
    np.testing.assert_allclose(flight.t, times, atol=1e-6)  # from the first record
    assert flight.trajectory == "step.csv" and flight.time_scale == 2.0
    assert flight.gains.kpos_i == (0.0, 0.0, 10.0) and flight.gains.mass == 0.032
    assert flight.weight == pytest.approx(WEIGHT, rel=1e-6)
    assert flight.cable_length == pytest.approx(0.5)  # 0.3 sideways, 0.4 down
    assert flight.payload_mass == pytest.approx(0.040 - PAYLOAD_VEHICLE_MASS, rel=1e-6)
    np.testing.assert_allclose(flight.setpoint[0], [0.0, 0.0, 1.0])
    k = np.arange(len(times))
    expected = np.stack([3 * ((k % 5) - 2), np.full(len(k), -2), k % 3], axis=1) / 1000.0
    np.testing.assert_allclose(flight.error, expected, atol=1e-12)


def test_the_counterpart_flies_the_log_s_flight(tmp_path):
    write_folder(tmp_path, 8, payload_offset=(0, 0, -510))
    flight = read_flight(tmp_path, 8)
    scenario = flight_scenario(flight, tmp_path / "traj")
    # the payload vehicle, and the rest of the weight on the log's cable
    assert scenario.vehicle.mass == pytest.approx(PAYLOAD_VEHICLE_MASS, rel=1e-6)
    assert scenario.disturbance.mass == pytest.approx(0.040 - PAYLOAD_VEHICLE_MASS, rel=1e-6)
    assert scenario.disturbance.cable_length == pytest.approx(0.51)
    assert scenario.dt == CONTROL_PERIOD
    # the file's path, shifted to start at the log's first setpoint, after the lead-in,
    # stretched by the time scale: half way at LEAD_IN + 1 s
    reference = scenario.trajectory.position_derivatives(
        np.array([0.0, LEAD_IN, LEAD_IN + 1.0, LEAD_IN + 2.0]))[0]
    np.testing.assert_allclose(reference, [[0, 0, 1], [0, 0, 1], [0.05, 0, 1], [0.1, 0, 1]],
                               atol=1e-12)


def test_the_weight_says_whether_a_payload_hangs(tmp_path):
    # log 183's case: heavy, its payload's fields all zero (untracked): the cable's 0.5 m
    write_folder(tmp_path, 12, payload_offset="untracked")
    flight = read_flight(tmp_path, 12)
    assert flight.cable_length == CABLE_LENGTH
    # log 178's case: a bare vehicle, whatever fields it logs
    write_folder(tmp_path, 13, payload_offset=(0, 0, -500), weight=BARE_WEIGHT)
    bare = read_flight(tmp_path, 13)
    assert bare.cable_length is None and bare.payload_mass == 0.0
    assert flight_scenario(bare, tmp_path / "traj").disturbance is None


def test_both_sides_are_scored_alike_and_written(tmp_path, capsys):
    write_folder(tmp_path, 9, weight=BARE_WEIGHT)  # a bare vehicle of the log's weight
    assert main(tmp_path, tmp_path / "traj", [9], [0, 1], tmp_path / "out") == 0
    summary = json.loads((tmp_path / "out" / "crazyswarm2.json").read_text())
    flight = read_flight(tmp_path, 9)
    real = summary["logs"]["9"]["real"]
    assert real["rms_total"] == pytest.approx(error_statistics(flight.error).rms_total)
    assert summary["logs"]["9"]["payload"] is False
    assert summary["logs"]["9"]["lost"] == 0
    simulated = summary["logs"]["9"]["simulated"]
    assert len(simulated) == 2 and all(s["samples"] == len(flight.t) for s in simulated)
    # the log's setpoint holds still where the file moves 0.1 m: their difference is the move
    tau = np.clip(flight.t / 2.0, 0.0, 1.0)
    moved = 0.1 * (3 * tau**2 - 2 * tau**3)
    assert summary["logs"]["9"]["reference_residual"] == pytest.approx(
        np.sqrt(np.mean(moved**2)), rel=1e-9)
    # the firmware's law flies a 0.1 m move at time scale 2 within centimetres
    assert 0.0 < summary["logs"]["9"]["sim_rms"][0] < 0.02
    assert "real RMS" in capsys.readouterr().out


def test_the_command_names_what_is_missing(tmp_path, capsys):
    write_folder(tmp_path, 10)
    with pytest.raises(SystemExit):
        cli_main(["real-flights", "crazyswarm2", "--logs", str(tmp_path), "--trajectories",
                  str(tmp_path / "traj"), "--log", "11", "--seeds", "1", "--out",
                  str(tmp_path / "out")])
    assert "logs/log11" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli_main(["real-flights", "crazyswarm2", "--logs", str(tmp_path / "nowhere"),
                  "--trajectories", str(tmp_path / "traj")])
    assert "is not a folder" in capsys.readouterr().err


def test_a_log_without_the_estimate_is_named(tmp_path):
    write_folder(tmp_path, 14)
    event = EventType(0xFFFF, "fixedFrequency", (("ctrlLee.thrustSI", "f"),))
    write_log(tmp_path / "logs" / "log14", [event], [(0xFFFF, 0.004 * k, (0.3,))
                                                     for k in range(10)])
    with pytest.raises(ValueError, match=r"stateEstimateZ\.x"):
        read_flight(tmp_path, 14)


def test_error_statistics_from_the_definitions():
    error = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 2.0]])
    size = error_statistics(error)
    assert size.rms.x == pytest.approx(np.sqrt(10 / 4))
    assert size.rms_total == pytest.approx(np.sqrt((25 + 1 + 4) / 4))
    assert size.max == 5.0 and size.samples == 4
    assert size.p95 == pytest.approx(np.percentile([5.0, 0.0, 1.0, 2.0], 95))
    with pytest.raises(ValueError, match=r"\(T, 3\)"):
        error_statistics(np.zeros((4, 2)))
