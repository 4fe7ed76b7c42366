"""Attitude metrics that do not saturate, and bootstrap intervals that cover."""

from __future__ import annotations

import numpy as np
import pytest

from quad_dob_env.so3 import exp
from quad_dob_training.evaluation.metrics import attitude_errors, error_euler_angles
from quad_dob_training.evaluation.statistics import bootstrap_mean, paired_difference


def _rz(angle):
    return exp(np.stack([np.zeros_like(angle), np.zeros_like(angle), angle], axis=1))


def test_a_pure_heading_error_is_all_heading_and_no_tilt():
    heading = np.linspace(-3.1, 3.1, 41)
    errors = attitude_errors(_rz(heading), np.tile(np.eye(3), (41, 1, 1)))
    np.testing.assert_allclose(errors["heading"], heading, atol=1e-12)
    np.testing.assert_allclose(errors["geodesic"], np.abs(heading), atol=1e-7)
    np.testing.assert_allclose(errors["tilt"], 0.0, atol=1e-7)


def test_tilt_and_heading_separate_in_any_composition():
    # E = Rz(psi) R_axis(phi) with the axis in the horizontal plane: the thrust axis is
    # tilted by phi, and what is left is a twist psi about body z (swing-twist)
    rng = np.random.default_rng(0)
    n = 200
    psi, phi, axis_angle = (rng.uniform(-3.0, 3.0, n), rng.uniform(0.0, 1.5, n),
                            rng.uniform(0, 2 * np.pi, n))
    swing = exp(np.stack([np.cos(axis_angle), np.sin(axis_angle), np.zeros(n)], 1)
                * phi[:, None])
    desired = exp(rng.normal(size=(n, 3)))
    rotation = desired @ (_rz(psi) @ swing)
    errors = attitude_errors(rotation, desired)
    np.testing.assert_allclose(errors["tilt"], phi, atol=1e-7)
    np.testing.assert_allclose(errors["heading"], psi, atol=1e-9)
    # the geodesic angle is the angle of the whole error rotation (trace formula)
    whole = np.swapaxes(desired, 1, 2) @ rotation
    cos = (np.trace(whole, axis1=1, axis2=2) - 1) / 2
    np.testing.assert_allclose(np.cos(errors["geodesic"]), cos, atol=1e-12)


def test_euler_angles_saturate_where_the_geodesic_does_not():
    # a heading wrapping uniformly: the Euler norm reads pi/sqrt(3) on average, whatever the
    # tilt; the tilt metric sees the tilt and the heading metric the wrapping heading
    heading = np.linspace(-np.pi, np.pi, 2001)[:-1]
    tilt = exp(np.tile([0.05, 0.0, 0.0], (2000, 1)))
    rotation = _rz(heading) @ tilt
    desired = np.tile(np.eye(3), (2000, 1, 1))
    euler_rms = np.sqrt(np.mean(np.sum(error_euler_angles(rotation, desired) ** 2, 1)))
    assert euler_rms == pytest.approx(np.pi / np.sqrt(3), rel=0.01)
    errors = attitude_errors(rotation, desired)
    np.testing.assert_allclose(errors["tilt"], 0.05, atol=1e-9)


def test_paired_difference_of_a_constant_shift_is_that_shift():
    base = np.random.default_rng(1).normal(1.0, 0.3, 20)
    interval = paired_difference(base - 0.1, base)
    assert interval.mean == pytest.approx(-0.1)
    assert interval.low == pytest.approx(-0.1) and interval.high == pytest.approx(-0.1)
    assert interval.excludes_zero()


def test_bootstrap_interval_covers_the_true_mean_about_95_percent_of_the_time():
    rng = np.random.default_rng(2)
    covered = [bootstrap_mean(rng.normal(0.5, 1.0, 20), resamples=2000, seed=k)
               for k in range(300)]
    rate = np.mean([interval.low <= 0.5 <= interval.high for interval in covered])
    # the percentile bootstrap under-covers a little at n = 20
    assert 0.88 <= rate <= 0.99


def test_bootstrap_refuses_empty_or_non_finite_values():
    with pytest.raises(ValueError, match="finite"):
        bootstrap_mean([])
    with pytest.raises(ValueError, match="finite"):
        bootstrap_mean([1.0, np.nan])
    with pytest.raises(ValueError, match="one value per seed"):
        paired_difference([1.0, 2.0], [1.0])


def test_evaluation_rows_carry_intervals_and_paired_differences():
    from quad_dob_training.evaluation.evaluate import SCORES, evaluate, markdown_table

    rows = evaluate(["geometric-ndob:tuned", "geometric"], ["hover-step-force"], [0, 1, 2])
    base, plain = rows
    for row in rows:
        for key, _ in SCORES:
            assert row[f"{key}_low"] <= row[f"{key}_mean"] <= row[f"{key}_high"]
        for key in ("rms_tilt_settled", "rms_heading_settled"):
            assert np.isfinite(row[f"{key}_mean"])
    assert base["rms_position_settled_diff_mean"] == 0.0 == base["rms_position_settled_diff_high"]
    difference = (plain["rms_position_settled_mean"] - base["rms_position_settled_mean"])
    assert plain["rms_position_settled_diff_mean"] == pytest.approx(difference)
    # without its observer the push of 0.2 weights shows: worse, and the interval says so
    assert plain["rms_position_settled_diff_low"] > 0
    table = markdown_table(rows)
    assert "Δ RMS ‖e_x‖ vs geometric-ndob:tuned" in table and "RMS tilt" in table


def test_the_command_rate_of_a_sinusoidal_rotor_dither_is_its_discrete_derivatives_rms():
    """f_i = c + a sin(ω t + φ_i) sampled every dt: each difference is
    2 a sin(ω dt / 2) cos(...), so over whole periods the RMS rate is √2 a sin(ω dt/2) / dt
    (a ω / √2 as dt → 0): the metric is the RMS of the rotor commands' rate, every rotor
    alike, over the settled steps only."""
    from dataclasses import replace

    from quad_dob_env import make_scenario
    from quad_dob_training.evaluation.metrics import flight_metrics
    from quad_dob_training.policies import Policy, fly_policy

    (flight,) = fly_policy(Policy("pid", "pid"), make_scenario("hover-calm"), [0])
    dt, amplitude, omega = flight.dt, 0.3, 2 * np.pi * 4.0  # 4 Hz, 100 steps a second
    time = flight.time
    dither = 2.0 + amplitude * np.sin(omega * time[:, None] + np.arange(4) * 0.7)
    dither[time < flight.settle_time] += 50.0 * time[time < flight.settle_time, None]  # unseen
    rated = replace(flight, requested_rotor_thrusts=dither)
    expected = np.sqrt(2) * amplitude * np.sin(omega * dt / 2) / dt
    assert flight_metrics(rated)["rms_command_rate"] == pytest.approx(expected, rel=2e-3)
    assert flight_metrics(replace(flight, actuation="wrench"))["rms_command_rate"] is None
    # the requested rotor thrusts are the command flown, through the allocation: their
    # collective is the requested thrust, and once settled (v1: no motor lag, nothing
    # saturated) their moment is the moment the core applied
    vehicle = make_scenario("hover-calm").vehicle
    wrench = flight.requested_rotor_thrusts @ vehicle.allocation_matrix.T
    np.testing.assert_allclose(wrench[:, 0], flight.requested_thrust, rtol=1e-12)
    settled = time >= flight.settle_time
    np.testing.assert_allclose(wrench[settled, 1:], flight.applied_moment[settled], atol=1e-9)


def test_a_residuals_command_rate_counts_its_own_dither():
    """A residual that alternates its thrust command each step: the command rate reported
    for it is the alternation's, far above its base's (the base alone does not dither)."""
    from quad_dob_composition import make_vector_env
    from quad_dob_env import make_scenario
    from quad_dob_training.evaluation.metrics import flight_metrics
    from quad_dob_training.policies import Policy, fly_policy

    class Alternating:
        def __init__(self, env):
            self.observation_space = env.single_observation_space
            self.action_space = env.single_action_space
            self.sign = 1.0

        def predict(self, observations, deterministic=True):
            self.sign = -self.sign
            actions = np.zeros((len(observations), 4))
            actions[:, 0] = 0.5 * self.sign
            return actions, None

    scenario = make_scenario("hover-calm")
    base = fly_policy(Policy("base", "geometric-ndob:tuned"), scenario, [0])[0]
    env = make_vector_env(1, scenario, base_controller="geometric-ndob:tuned")
    thrust_range = env.residual.residual_range[0]
    dithered = Policy("dither", "geometric-ndob:tuned", Alternating(env),
                      {"env_kwargs": {}})
    flight = fly_policy(dithered, scenario, [0])[0]
    rate, base_rate = (flight_metrics(f)["rms_command_rate"] for f in (flight, base))
    # each step the collective flips by 2 · 0.5 · range: a quarter of it on each rotor
    expected = 2 * 0.5 * thrust_range / 4 / scenario.dt
    assert rate == pytest.approx(expected, rel=0.05) and base_rate < 0.05 * rate
