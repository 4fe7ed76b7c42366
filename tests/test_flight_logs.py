"""Flight logs and their statistics (``quad_dob_training.wind_tunnel.flight_logs``,
``flight_statistics``, ``wind_tunnel_tool``), held to synthetic logs with planted errors.

Neural-Fly's data is never read here: every log is written by these tests, in their format,
from a known model, and each statistic must give back what was planted in it."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from quad_dob_training.wind_tunnel.flight_logs import (
    FlightLog,
    log_from_infos,
    read_neural_fly,
    read_neural_fly_folder,
    write_neural_fly,
)
from quad_dob_training.wind_tunnel.flight_statistics import (
    LIMIT_PWM,
    fa_reconstruction_rms,
    harmonics,
    lap_periodic_share,
    lap_window,
    log_statistics,
    reconstruct_fa,
)
from quad_dob_training.wind_tunnel.verdicts import TOLERANCES, verdicts, within

M, G, HOVER = 2.53, 9.81, 0.48  # Neural-Fly's mass [kg], g, a hover throttle


def figure8(duration: float = 40.0, dt: float = 0.02, *, gain: float = 1.0, lag: float = 0.0,
            force=(0.0, 0.0, 0.0), error=None, method: str = "indi",
            condition: str = "35wind") -> FlightLog:
    """A vehicle on Neural-Fly's figure-8 (x centred at 0.25 m as theirs), position p_d +
    ``error(t)`` (velocity the reference's plus the error's derivative), its thrust along
    body z holding the reference's acceleration against ``force`` [N]. The true thrust
    T_a = |m (a + g e3) - F| is ``gain`` times what was commanded after a first-order
    ``lag`` [s]: T_c = (T_a + lag Ṫ_a) / gain, logged as T_sp = hover T_c / (m g)."""
    t = np.arange(0.0, duration, dt)
    zero, s, c = np.zeros_like(t), np.sin, np.cos
    p_d = np.stack([0.25 + 1.25 * s(t), zero, 2.15 + 0.75 * s(2 * t)], axis=1)
    v_d = np.stack([1.25 * c(t), zero, 1.5 * c(2 * t)], axis=1)
    a_d = np.stack([-1.25 * s(t), zero, -3.0 * s(2 * t)], axis=1)
    j_d = np.stack([-1.25 * c(t), zero, -6.0 * c(2 * t)], axis=1)
    # the thrust vector: m a = f - m g e3 + F
    f = M * (a_d + np.array([0.0, 0.0, G])) - np.asarray(force)
    thrust = np.linalg.norm(f, axis=1)
    b3 = f / thrust[:, None]
    b2 = np.cross(b3, [1.0, 0.0, 0.0])  # heading along +x, as theirs
    b2 /= np.linalg.norm(b2, axis=1)[:, None]
    rotation = np.stack([np.cross(b2, b3), b2, b3], axis=2)
    rate = M * np.sum(f * j_d, axis=1) / thrust  # d|f|/dt, F constant
    commanded = (thrust + lag * rate) / gain
    p_error, v_error = error(t) if error is not None else (0.0, 0.0)
    return FlightLog(t=t, p=p_d + p_error, p_d=p_d, v=v_d + v_error, v_d=v_d, R=rotation,
                     T_sp=HOVER * commanded / (M * G), hover_throttle=np.full(len(t), HOVER),
                     fa=np.tile(force, (len(t), 1)), method=method, condition=condition,
                     mass=M)


def _written(tmp_path, log: FlightLog, name: str = "custom_figure8_indi_35wind.csv"):
    return write_neural_fly(log, tmp_path / name)


# --- reading and writing Neural-Fly's format ------------------------------------------------

def test_the_reader_gives_back_what_the_writer_wrote_in_neural_flys_format(tmp_path):
    log = figure8(duration=8.0)
    pwm = np.tile([1100.0, 1110.0, 1120.0, 1130.0], (len(log.t), 1))
    quaternion = np.tile([0.0, 0.0, 0.0, 1.0], (len(log.t), 1))  # a column the reader skips
    path = write_neural_fly(replace(log, pwm=pwm),
                            tmp_path / "custom_figure8_NF-C_70p20sint.csv", {"q": quaternion})
    lines = path.read_text().splitlines()
    # their header: an unnamed index column first; q where their order puts it
    assert lines[0] == ",t,p,p_d,v,v_d,q,R,T_sp,hover_throttle,fa,pwm"
    first = lines[1]
    assert first.startswith("0,0.0,\"[0.25, 0.0, 2.15]\"")
    assert f",[{HOVER!r}]," in first and "\"[[" in first  # a scalar as [T]; R nested
    read = read_neural_fly(path)
    for name in ("t", "p", "p_d", "v", "v_d", "R", "T_sp", "hover_throttle", "fa", "pwm"):
        np.testing.assert_array_equal(getattr(read, name), getattr(log, name)
                                      if name != "pwm" else pwm)
    assert (read.method, read.condition, read.wind_speed, read.mass) == \
        ("NF-C", "70p20sint", None, M)
    assert read_neural_fly(_written(tmp_path, log)).wind_speed == 4.2


def test_a_folder_is_read_in_name_order_and_other_files_are_left_alone(tmp_path):
    log = figure8(duration=3.0)
    for name in ("custom_figure8_NF_100wind.csv", "custom_figure8_L1_nowind.csv"):
        _written(tmp_path, log, name)
    (tmp_path / "notes.txt").write_text("not a log")
    logs = read_neural_fly_folder(tmp_path)
    assert [(x.method, x.wind_speed) for x in logs] == [("L1", 0.0), ("NF", 12.1)]


def test_bad_input_is_refused_naming_what_is_wrong_and_what_is_allowed(tmp_path):
    log = figure8(duration=3.0)
    path = _written(tmp_path, log)
    header, *rows = path.read_text().splitlines()
    # a missing column
    (tmp_path / "cut").mkdir()
    cut = tmp_path / "cut" / path.name
    columns = header.split(",")
    keep = [k for k, name in enumerate(columns) if name != "T_sp"]
    with open(path, newline="") as source, open(cut, "w", newline="") as target:
        writer = csv.writer(target)
        for row in csv.reader(source):
            writer.writerow([row[k] for k in keep])
    with pytest.raises(ValueError, match=r"missing column\(s\) T_sp; a Neural-Fly .* has t, p"):
        read_neural_fly(cut)
    # an unknown condition or method in the name
    for name, message in (("custom_figure8_indi_50wind.csv",
                           r"unknown condition '50wind'.*nowind, 35wind, 70wind, 100wind"),
                          ("custom_figure8_pid_nowind.csv", r"unknown method 'pid'.*NF-C")):
        (tmp_path / "bad").mkdir(exist_ok=True)
        bad = tmp_path / "bad" / name
        bad.write_text(path.read_text())
        with pytest.raises(ValueError, match=message):
            read_neural_fly(bad)
        bad.unlink()
    with pytest.raises(ValueError, match=r"not named custom_figure8_<METHOD>_<COND>\.csv"):
        read_neural_fly(tmp_path / "figure8.csv")
    # a folder without a matching file, and one that is not there
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "custom_random3_baseline_nowind.csv").write_text(header)
    with pytest.raises(ValueError, match=r"holds no custom_figure8_<METHOD>_<COND>\.csv"):
        read_neural_fly_folder(tmp_path / "empty")
    with pytest.raises(ValueError, match="is not a folder"):
        read_neural_fly_folder(tmp_path / "nowhere")
    # a cell of the wrong width, or not a number
    (tmp_path / "cells").mkdir()
    for old, new, message in (("\"[0.25, 0.0, 2.15]\"", "\"[0.25, 0.0]\"",
                               "row 1, column 'p' holds 2 numbers; p has 3"),
                              ("\"[0.25, 0.0, 2.15]\"", "\"[0.25, 0.0, x]\"",
                               "row 1, column 'p'.*is not a number")):
        broken = tmp_path / "cells" / path.name
        broken.write_text("\n".join([header, rows[0].replace(old, new, 1), *rows[1:]]))
        with pytest.raises(ValueError, match=message):
            read_neural_fly(broken)
    with pytest.raises(ValueError, match=r"FlightLog.R must have shape \(150, 3, 3\)"):
        replace(log, R=log.R[:, :2])


# --- the whole laps ---------------------------------------------------------------------------

def test_the_scored_laps_are_the_whole_laps_after_5_s_by_the_references_phase():
    """φ = t: laps start at 2π k; 50 s hold 6 whole laps after 5 s, [2π, 14π]. A reference
    running late by 1 s starts its laps 1 s later: the laps follow p_d, not the clock."""
    window = lap_window(figure8(duration=50.0, dt=0.01))
    assert window.laps == 6
    np.testing.assert_allclose(window.boundaries, 2 * np.pi * np.arange(1, 8), atol=1e-6)
    assert lap_window(figure8(duration=50.0), laps=3).end == pytest.approx(8 * np.pi, abs=1e-5)
    late = figure8(duration=50.0)
    late = replace(late, t=late.t + 1.0)
    assert lap_window(late).start == pytest.approx(2 * np.pi + 1.0, abs=1e-5)
    with pytest.raises(ValueError, match="7 laps asked for; it holds 1 to 6 whole laps"):
        lap_window(figure8(duration=50.0), laps=7)
    with pytest.raises(ValueError, match=r"no whole lap of the figure-8 after 5 s within its "
                                         r"11\.0 s"):
        lap_window(figure8(duration=11.0))


def test_a_sinusoid_comes_out_at_its_amplitude():
    """On whole laps at 50 Hz (314.16 samples a lap: not a whole number) each harmonic's
    amplitude is the sinusoid's, whatever its phase, and the others' nothing."""
    log = figure8(duration=45.0)
    t = log.t
    error = np.stack([0.03 * np.sin(t + 0.4), 0.01 * np.cos(3 * t - 1.0),
                      0.02 * np.sin(2 * t) + 0.005 * np.cos(t)], axis=1)
    found = {h.harmonic: h.amplitude for h in harmonics(error, t, lap_window(log))}
    expected = {1: (0.03, 0.0, 0.005), 2: (0.0, 0.0, 0.02), 3: (0.0, 0.01, 0.0)}
    for k, amplitudes in expected.items():
        # exact but for the lap starts, interpolated between samples (1e-10 of a lap)
        np.testing.assert_allclose([found[k].x, found[k].y, found[k].z], amplitudes,
                                   rtol=0, atol=1e-10)


def test_a_sinusoids_phase_comes_out_against_the_laps_phase():
    """z = A cos(2φ - θ) with φ the lap's phase (φ = t on this figure-8, 0 where p_d crosses
    its x centre moving +x): the second harmonic's phase is θ, wrapped into (-π, π]."""
    log = figure8(duration=45.0)
    t = log.t
    for theta in (0.3, -2.0, 3.0):
        error = np.stack([np.zeros_like(t), np.zeros_like(t), 0.02 * np.cos(2 * t - theta)],
                         axis=1)
        second = {h.harmonic: h for h in harmonics(error, t, lap_window(log))}[2]
        assert second.amplitude.z == pytest.approx(0.02, abs=1e-10)
        # the lap starts are interpolated between samples: 1e-7 s off a sine's crossing
        assert second.phase.z == pytest.approx(theta, abs=2e-6)


def test_the_lap_periodic_share_is_the_power_that_repeats_each_lap():
    """Planted: a lap-periodic error of power P and white noise of power N over L = 8
    laps. The share is 1 for the periodic alone (less the 64 bins' smoothing of harmonics
    1-3: under 1 %), bins / samples for the noise alone (what it leaks into the bins'
    means), and their mix in between, each power weighted so."""
    log = figure8(duration=9 * 2 * np.pi + 0.5)  # lap starts at 2π, 4π, ..., 18π
    t, window = log.t, lap_window(log)
    assert window.laps == 8
    kept = window.mask(t)
    samples = int(kept.sum())
    periodic = np.stack([0.03 * np.sin(t), 0.01 * np.cos(3 * t), 0.02 * np.sin(2 * t + 1)],
                        axis=1)
    assert lap_periodic_share(periodic, t, window) == pytest.approx(1.0, abs=0.01)
    noise = np.random.default_rng(0).normal(0.0, 0.02, (len(t), 3))
    leak = 64 / samples
    assert lap_periodic_share(noise, t, window) == pytest.approx(leak, rel=0.2)
    p_power = np.sum(periodic[kept] ** 2)
    n_power = np.sum(noise[kept] ** 2)
    assert lap_periodic_share(periodic + noise, t, window) == pytest.approx(
        (p_power + leak * n_power) / (p_power + n_power), rel=0.03)
    assert math.isnan(lap_periodic_share(periodic, t, lap_window(log, laps=1)))


def test_the_command_over_hover_and_the_share_at_a_limit():
    """The collective command over the hover command, mean and peak, over the scored laps;
    the share of scored samples at a limit: a real log's PWM at 1990 of 1999 or more on
    any motor, a simulated log's own flag."""
    log = figure8(duration=30.0)
    window = lap_window(log)
    kept = window.mask(log.t)
    ratio = log.T_sp / log.hover_throttle
    statistics = log_statistics(log)
    assert statistics.command_over_hover_mean == pytest.approx(ratio[kept].mean(), rel=1e-12)
    assert statistics.command_over_hover_peak == pytest.approx(ratio[kept].max(), rel=1e-12)
    assert math.isnan(statistics.limit_share)  # neither PWM nor a flag: unknown
    pwm = np.full((len(log.t), 4), 1500.0)
    pwm[::10, 2] = LIMIT_PWM  # one motor at the limit every tenth sample
    pwm[5::10, 0] = LIMIT_PWM - 1  # just below: not at it
    real = replace(log, pwm=pwm)
    expected = np.mean((np.arange(len(log.t)) % 10 == 0)[kept])
    assert log_statistics(real).limit_share == pytest.approx(expected, rel=1e-12)
    flags = (np.arange(len(log.t)) % 4 == 0).astype(float)
    simulated = replace(log, at_limit=flags)
    assert log_statistics(simulated).limit_share == pytest.approx(flags[kept].mean(),
                                                                  rel=1e-12)


def test_a_simulated_log_carries_the_steps_at_a_limit():
    from quad_dob_env import make_scenario
    from quad_dob_env.envs import QuadrotorVectorEnv
    from quad_dob_training.wind_tunnel.flight_logs import InfoRecorder

    env = QuadrotorVectorEnv(2, make_scenario("hover-calm", duration=0.3))
    _, info = env.reset(seed=[1, 2])
    recorder = InfoRecorder(2)
    saturated = []
    for step in range(20):
        recorder.add(info)
        saturated.append(info["actuator_saturated"].copy())
        # full thrust and a full roll moment every other step: the mixer clips a rotor
        action = np.zeros((2, 4))
        action[:, :2] = 1.0 if step % 2 else 0.0
        _, _, terminated, truncated, info = env.step(action)
        recorder.ended(terminated, truncated)
    logs = recorder.logs(env.core.vehicle)
    flags = np.array(saturated)
    assert flags.any() and not flags.all()
    for i, log in enumerate(logs):
        np.testing.assert_array_equal(log.at_limit, flags[: len(log.t), i].astype(float))


@pytest.mark.parametrize(("statistic", "real", "simulated", "inside"), [
    ("mean_fa_x", 14.7, 14.7 * 1.149, True), ("mean_fa_x", 14.7, 14.7 * 1.151, False),
    ("mean_fa_x", 14.7, 14.7 * 0.851, True), ("mean_fa_x", 14.7, 14.7 * 0.849, False),
    ("command_over_hover_mean", 1.26, 1.359, True), ("command_over_hover_mean", 1.26, 1.161,
                                                      True),
    ("command_over_hover_mean", 1.26, 1.361, False),
    ("command_over_hover_peak", 1.58, 1.729, True), ("command_over_hover_peak", 1.58, 1.429,
                                                      False),
    ("limit_share", 0.0, 0.0199, True), ("limit_share", 0.0, 0.02, False),
    ("rms_total", 0.122, 0.122 * 1.499, True), ("rms_total", 0.122, 0.122 / 1.49, True),
    ("rms_total", 0.122, 0.122 * 1.51, False), ("rms_total", 0.122, 0.122 / 1.51, False),
    ("z_share", 0.78, 0.929, True), ("z_share", 0.78, 0.629, False),
    ("mean.x", -0.193, -0.0966, True), ("mean.x", -0.193, -0.385, True),
    ("mean.x", -0.193, -0.0964, False), ("mean.x", -0.193, 0.150, False),
    ("mean.x", 0.012, -0.049, True), ("mean.x", 0.012, 0.051, False),
    ("mean.z", 0.05, 0.0799, True), ("mean.z", 0.05, 0.0801, False)])
def test_each_tolerance_holds_its_targets_edge(statistic, real, simulated, inside):
    (tolerance,) = [t for t in TOLERANCES if t.statistic == statistic]
    assert within(tolerance, real, simulated) is inside


def test_verdicts_name_the_tolerance_where_a_target_applies_and_the_ratio_elsewhere():
    real = {"mean_fa_x": 14.7, "rms_total": 0.122, "z_share": 0.78, "mean.x": -0.193,
            "mean.z": 0.01, "command_over_hover_mean": 1.26, "command_over_hover_peak": 1.58,
            "limit_share": 0.0, "rms.x": 0.1, "rms.y": 0.02, "rms.z": 0.05,
            "harmonics.1.z": 0.01, "harmonics.2.z": 0.02, "harmonics.2.phase.z": 3.0,
            "lap_periodic_share": 0.6}
    simulated = {**real, "mean_fa_x": 20.2, "rms_total": 0.113, "rms.x": 0.15,
                 "harmonics.2.phase.z": -3.0}
    rows = {row["statistic"]: row for row in verdicts(real, simulated, 12.1)}
    assert rows["mean fa_x"]["verdict"].startswith("outside: within 15% of the real")
    assert rows["RMS"]["verdict"].startswith("within: within 1.5x of the real")
    assert "z share" not in rows  # a calm-air target only
    assert rows["RMS x"]["verdict"] == "sim / real 1.50"
    # -3.0 - 3.0 rad wraps to +0.28 rad: the phases are 16° apart, not 344°
    wrapped = math.degrees(2 * math.pi - 6.0)
    assert rows["z phase at 2 rad/s"]["verdict"] == f"sim - real {wrapped:+.0f}°"
    calm = {row["statistic"] for row in verdicts(real, simulated, 0.0)}
    assert "z share" in calm and "mean fa_x" not in calm and "at a limit" not in calm


# --- planted errors -------------------------------------------------------------------------

def test_a_constant_vertical_offset_is_the_signed_mean_and_its_share(tmp_path):
    """p = p_d + (A sin t, 0, δ): the mean z error is δ, the x one 0, rms_x = A / √2, and
    the z share δ² / (δ² + A²/2), read back from the CSV."""
    A, delta = 0.03, -0.02

    def error(t):
        zero = np.zeros_like(t)
        return (np.stack([A * np.sin(t), zero, zero + delta], axis=1),
                np.stack([A * np.cos(t), zero, zero], axis=1))

    log = read_neural_fly(_written(tmp_path, figure8(duration=45.0, error=error)))
    statistics = log_statistics(log)
    assert statistics.mean.z == pytest.approx(delta, abs=1e-12)
    assert abs(statistics.mean.x) < 1e-4 * A and statistics.rms.z == pytest.approx(-delta)
    assert statistics.rms.x == pytest.approx(A / math.sqrt(2), rel=1e-3)
    assert statistics.z_share == pytest.approx(delta ** 2 / (delta ** 2 + A ** 2 / 2), rel=1e-3)
    assert statistics.rms_total == pytest.approx(math.hypot(A / math.sqrt(2), delta), rel=1e-3)
    assert statistics.harmonics[0].amplitude.x == pytest.approx(A, rel=1e-9)


def test_a_thrust_gain_error_is_the_fits_a_and_c(tmp_path):
    """True thrust k times the command: fa_z = m (v̇_z + g) - T_c R33 = (1 - 1/k) m (v̇_z + g),
    so a = m (1 - 1/k), b = 0, c = m g (1 - 1/k)."""
    k = 1.1
    log = read_neural_fly(_written(tmp_path, figure8(duration=45.0, gain=k)))
    fit = log_statistics(log).fa_z_fit
    assert fit.a == pytest.approx(M * (1 - 1 / k), rel=0.01)
    assert fit.c == pytest.approx(M * G * (1 - 1 / k), rel=0.01)
    assert abs(fit.b) < 0.01 and abs(fit.tau) < 0.001 and fit.r_squared > 0.999


@pytest.mark.parametrize("lag", [0.03, 0.08])
def test_a_first_order_thrust_lag_is_found_as_tau(tmp_path, lag):
    """T_a + τ Ṫ_a = T_c: fa_z ≈ -τ Ṫ_c ≈ 4 m τ v_z on the 2 rad/s vertical motion, so
    b / (4 m) is τ, within 3 % (the horizontal motion's share of Ṫ, (a/g)² small)."""
    log = read_neural_fly(_written(tmp_path, figure8(duration=45.0, lag=lag)))
    fit = log_statistics(log).fa_z_fit
    assert fit.tau == pytest.approx(lag, rel=0.03)
    assert fit.b == pytest.approx(4 * M * lag, rel=0.03) and fit.r_squared > 0.99


def test_the_residual_force_is_reconstructed_from_the_logged_fields(tmp_path):
    """A constant force F against the flight: fa = m (v̇ + g e3) - (T_sp / t_h) m g R e3
    gives F back (central differences: within 5 mN), the log's own fa too."""
    force = (-6.0, 0.8, 1.5)
    log = read_neural_fly(_written(tmp_path, figure8(duration=20.0, force=force)))
    fa = reconstruct_fa(log)
    assert np.isnan(fa[0]).all() and np.isnan(fa[-1]).all()
    np.testing.assert_allclose(fa[1:-1], np.tile(force, (len(fa) - 2, 1)), rtol=0, atol=5e-3)
    assert max(vars(fa_reconstruction_rms(log)).values()) < 5e-3
    assert log_statistics(log).mean_fa_x == pytest.approx(force[0], abs=5e-3)


# --- the simulated side ---------------------------------------------------------------------

def test_a_simulated_log_is_the_rollouts_record_and_its_command():
    """The env's info makes the same flight as the rollout records: position, velocity,
    reference, and T_sp / hover throttle m g the thrust the controller commanded."""
    from quad_dob_env.scenarios import make_scenario
    from quad_dob_training.policies import fly_policy, make_policy
    from quad_dob_training.wind_tunnel.tool import fly_logs

    scenario = make_scenario("figure8-wind-4.2", benchmark="v2", duration=3.0)
    (log,) = fly_logs("indi", scenario, [3], 4.2)
    (flight,) = fly_policy(make_policy("indi"), scenario, [3])
    np.testing.assert_allclose(log.t, flight.time, rtol=0, atol=1e-12)
    for mine, theirs in (("p", "position"), ("v", "velocity"), ("p_d", "reference_position"),
                         ("R", "estimated_rotation")):
        np.testing.assert_allclose(getattr(log, mine), getattr(flight, theirs), atol=1e-12)
    thrust = log.T_sp / log.hover_throttle * log.mass * 9.81
    np.testing.assert_allclose(thrust, flight.requested_thrust, rtol=1e-12)
    assert "commanded" in log.thrust_source and log.mass == 2.53 and not log.crashed


def test_the_adapter_takes_the_envs_thrust_setpoint_where_it_reports_one():
    from quad_dob_env.params import get_vehicle

    vehicle = get_vehicle("neural-fly")
    steps = [{"time": 0.01 * k, "reference_position": np.zeros(3), "position_error": np.zeros(3),
              "reference_velocity": np.zeros(3), "velocity_error": np.zeros(3),
              "estimate": {"rotation": np.eye(3)}, "applied_thrust": 20.0, "base_thrust": 30.0}
             for k in range(4)]
    full = vehicle.max_total_thrust
    log = log_from_infos(steps, vehicle)
    np.testing.assert_allclose(log.T_sp / log.hover_throttle, 30.0 / (vehicle.mass * 9.81))
    assert log.T_sp[0] == pytest.approx(30.0 / full) and "commanded" in log.thrust_source
    applied = log_from_infos([{k: v for k, v in s.items() if k != "base_thrust"}
                              for s in steps], vehicle)
    assert applied.T_sp[0] == pytest.approx(20.0 / full) and "applied" in applied.thrust_source
    reported = log_from_infos([{**s, "thrust_setpoint": 0.5, "hover_throttle": 0.45}
                               for s in steps], vehicle)
    assert reported.T_sp[0] == 0.5 and reported.hover_throttle[0] == 0.45
    assert reported.thrust_source == "info thrust_setpoint / hover_throttle"


def test_the_wind_tunnel_counterparts_and_benchmark():
    from quad_dob_env.benchmark import TOOLS_BENCHMARK
    from quad_dob_training.wind_tunnel.flight_logs import NEURAL_FLY_METHODS
    from quad_dob_training.wind_tunnel.published import counterparts

    assert TOOLS_BENCHMARK == "v4"

    def simulated_of(pairs):  # Neural-Fly's method -> the controller flown for it
        return {method: spec for method, label in NEURAL_FLY_METHODS.items()
                for spec, real in pairs.items() if real == label}

    stand_ins = {"baseline": "geometric-integral", "indi": "indi", "L1": "l1",
                 "NF-C": "geometric-ndob:tuned"}
    for benchmark in ("v1", "v2", "v3"):
        assert simulated_of(counterparts(benchmark)) == stand_ins
    assert simulated_of(counterparts("v3", "stand-ins")) == stand_ins
    # v4's: the laws Neural-Fly flew, by names of their own
    assert simulated_of(counterparts("v4")) == {"baseline": "nf-baseline", "indi": "indi-outer",
                                                "L1": "l1-matched", "NF-C": "nf-constant"}
    assert counterparts("v4", "stand-ins") == counterparts("v3")
    with pytest.raises(ValueError, match="unknown counterparts 'nf'; valid: stand-ins, "
                                         "neural-fly"):
        counterparts("v4", "nf")


@pytest.mark.slow
def test_the_command_scores_both_sides_over_the_same_laps(tmp_path, capsys):
    """One seed; synthetic logs of 14 s (one whole lap after 5 s), so the simulation flies
    14 s: a counterpart's run side by side, two runs without one real only."""
    from quad_dob_training import cli

    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("indi_35wind", "NF_nowind", "L1_70p20sint"):
        _written(logs, figure8(duration=14.0), f"custom_figure8_{name}.csv")
    out = tmp_path / "out"
    # v2: the loop whose gains were tuned, so that no flight is lost and both sides score
    assert cli.main(["wind-tunnel", "--benchmark", "v2", "--seeds", "9001-9001",
                     "--neural-fly", str(logs), "--out", str(out)]) == 0
    console = capsys.readouterr().out
    # the console's tables fit 120 columns; wind_tunnel.md holds every column
    assert max(len(line) for line in console.splitlines()) <= 120
    assert "Sim against real over the same whole laps, 3 runs:" in console
    assert "geometric-ndob:tuned (sim)" in console and "NF-C (real)" in console
    printed = (out / "wind_tunnel.md").read_text()
    assert "| indi 35wind | real |" in printed and "| indi 35wind | sim: indi |" in printed
    assert "| NF nowind | real |" in printed and "NF nowind | sim" not in printed
    assert "(2 runs without a counterpart: real only)" in printed
    # the verdict table: at 4.2 m/s the force's target applies, and the RMS's
    assert "| indi 35wind | indi | mean fa_x |" in printed
    assert "| indi 35wind | indi | RMS |" in printed and "NF nowind | " not in printed.split(
        "Sim against real")[1]
    assert "| geometric-ndob:tuned (sim) |" in printed and "| NF-C (real) | 52 |" in printed
    document = json.loads((out / "wind_tunnel.json").read_text())
    assert document["benchmark"] == "v2" and document["seeds"] == [9001]
    assert len(document["simulated"]) == 16
    assert all(run["duration"] == pytest.approx(13.98) for run in document["simulated"])
    (indi,) = [row for row in document["real"] if row["counterpart"] == "indi"]
    assert indi["laps"] == 1 == indi["simulated"]["laps"] == indi["statistics"]["laps"]
    assert indi["statistics"]["rms_total"] == 0.0  # the synthetic vehicle flew p_d
    assert max(indi["fa_reconstruction_rms"].values()) < 5e-3
    assert [row["counterpart"] for row in document["real"]].count(None) == 2
    for name in ("rms_by_wind.png", "axes_by_wind.png", "forces_by_wind.png"):
        assert (out / name).stat().st_size > 1000


def test_the_command_refuses_before_flying(tmp_path, capsys):
    from quad_dob_training import cli

    (tmp_path / "empty").mkdir()
    for arguments, message in (
            (["--neural-fly", str(tmp_path / "empty")], "holds no custom_figure8_"),
            (["--duration", "10"], "--duration 10 s holds no whole lap after 5 s")):
        with pytest.raises(SystemExit) as exited:
            cli.main(["wind-tunnel", "--out", str(tmp_path / "out"), *arguments])
        assert exited.value.code == 2
        assert message in capsys.readouterr().err


# --- the evaluation rows --------------------------------------------------------------------

def test_the_z_share_never_rounds_above_one():
    """A landing straight down (v1's ground-effect-landing, pid, 20 seeds: no horizontal
    error at all) made a share of 1 + 2e-16, which evaluation.json's schema refused."""
    from quad_dob_training.evaluation.statistics import z_share

    rng = np.random.default_rng(0)
    for _ in range(20000):
        flights = rng.integers(1, 25)
        rms = np.abs(rng.normal(size=(flights, 3))) * np.array([1e-9, 1e-9, 1.0]) \
            * rng.uniform(0.1, 10, size=(flights, 1))
        assert 0.0 <= z_share(rms) <= 1.0
    assert z_share([0.0, 0.0, 0.3]) == 1.0
    assert z_share([0.3, 0.4, 0.0]) == 0.0


def test_evaluation_rows_hold_the_settled_rms_per_axis_and_the_z_share():
    """rms_position_settled_{x,y,z}_{mean,std,low,high} as the norm's, and z_share_settled =
    Σ rms_z² / Σ rms² over the seeds; the rows still make a valid evaluation.json."""
    from quad_dob_training.evaluation.evaluate import evaluate
    from quad_dob_training.evaluation.results import results_document, validate

    per_seed: dict = {}
    (row,) = evaluate(["pid"], ["figure8-wind-4.2"], [1, 2], baseline=None,
                      scenario_options={"benchmark": "v2", "duration": 6.0},
                      per_seed=per_seed)
    metrics = per_seed["figure8-wind-4.2", "pid"]
    for axis in "xyz":
        values = [m[f"rms_position_settled_{axis}"] for m in metrics]
        assert row[f"rms_position_settled_{axis}_mean"] == pytest.approx(np.mean(values))
        assert row[f"rms_position_settled_{axis}_std"] == pytest.approx(np.std(values))
        assert row[f"rms_position_settled_{axis}_low"] <= np.mean(values) <= \
            row[f"rms_position_settled_{axis}_high"]
    squares = [m["rms_position_settled"] ** 2 for m in metrics]
    axes = [sum(m[f"rms_position_settled_{a}"] ** 2 for a in "xyz") for m in metrics]
    np.testing.assert_allclose(axes, squares, rtol=1e-12)  # the norm's RMS is the axes'
    z = sum(m["rms_position_settled_z"] ** 2 for m in metrics)
    assert row["z_share_settled"] == pytest.approx(z / sum(squares), rel=1e-12)
    validate(results_document([row], [1, 2], {"benchmark": "v2"}), "these rows")
