"""The statistics of a figure-8 flight log, one implementation for real and simulated logs.

Everything is scored over the same whole laps after 5 s (``lap_window``). The figure-8 is
``x = x_c + 1.25 sin φ, z = z_c + 0.75 sin 2φ`` with ``φ = t`` once it is up to speed; a
lap starts where the reference ``p_d`` crosses the centre of its x swing moving +x (φ ≡ 0
mod 2π), found by linear interpolation between samples. The scored laps are the whole laps
from the first such crossing at or after 5 s to the last one within the log (or the first
``laps`` of them, so that two logs are scored over as many laps). Neural-Fly's reference
starts at rest and takes its first lap more slowly; ours flies φ = t from the start: the
rule finds each one's own laps by the reference, not by the clock.

``log_statistics`` returns ``LogStatistics``: the RMS position error per axis and in all,
the signed mean error, the vertical share of the squared error, the error's Fourier
amplitudes at the lap's harmonics 1, 2, 3 (1, 2, 3 rad/s at φ = t), the fit
``fa_z ≈ a a_z + b v_z + c`` with the thrust lag it implies, the mean ``fa_x`` and the hover
throttle at the start and the end; the error's phase at each harmonic, its lap-periodic
share, the commanded collective thrust over the hover command (mean and peak) and the share
of samples with the actuators at a limit. ``reconstruct_fa`` is the residual force from the
logged fields (``docs/wind-tunnel-tool.md`` derives each formula).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from quad_dob_training.evaluation.statistics import AxisValues, error_statistics, z_share
from quad_dob_training.wind_tunnel.flight_logs import FlightLog

SKIP = 5.0  # [s] Neural-Fly's table scores after the first 5 s
GRAVITY = 9.81  # [m/s²] as Neural-Fly's fa
HARMONICS = (1, 2, 3)  # the lap's harmonics scored: 1, 2, 3 rad/s at φ = t
SMOOTHING_SPAN = 0.5  # [s] the centred moving average of the fa_z fit
VERTICAL_FREQUENCY = 2.0  # [rad/s] the figure-8's vertical motion, z = z_c + 0.75 sin 2t
HOVER_SPAN = 1.0  # [s] the hover throttle at the start and end: its mean over this span
# a real log's actuators are at their limit where a motor's PWM reads 1990 or more of its
# 1999 (Neural-Fly's logs: the only 1999s are a 0.1 s start-up transient, issue 54)
LIMIT_PWM = 1990.0
PERIODIC_BINS = 64  # phase bins a lap is cut into for the lap-periodic share


@dataclass(frozen=True)
class LapWindow:
    """The scored whole laps: ``boundaries`` [s] are the lap starts and the last lap's end
    (``laps`` + 1 of them); samples with ``start <= t < end`` are scored."""

    start: float
    end: float
    laps: int
    boundaries: tuple[float, ...]

    def mask(self, t: NDArray) -> NDArray[np.bool_]:
        return (t >= self.start) & (t < self.end)


@dataclass(frozen=True)
class FazFit:
    """Least squares ``fa_z ≈ a a_z + b v_z + c`` on the smoothed series over the scored
    laps: ``a`` [kg], ``b`` [kg/s], ``c`` [N], ``r_squared``, and ``tau`` = b / (4 m) [s],
    the first-order thrust lag that ``b`` means for the 2 rad/s vertical motion."""

    a: float
    b: float
    c: float
    r_squared: float
    tau: float
    samples: int


@dataclass(frozen=True)
class Harmonic:
    """The error's single-sided Fourier amplitude [m] per axis at ``harmonic`` times the
    lap's frequency (``harmonic`` rad/s once a lap takes 2π s)."""

    harmonic: int
    amplitude: AxisValues
    # [rad] the component is ``amplitude cos(k φ - phase)``, φ the lap's phase (0 where p_d
    # crosses its x centre moving +x), in (-π, π]
    phase: AxisValues


@dataclass(frozen=True)
class LogStatistics:
    window: LapWindow
    rms: AxisValues  # [m] RMS of p - p_d per axis over the scored laps
    rms_total: float  # [m] RMS of |p - p_d|
    mean: AxisValues  # [m] signed mean of p - p_d
    z_share: float  # rms_z² / rms_total²
    harmonics: tuple[Harmonic, ...]
    fa_z_fit: FazFit
    mean_fa_x: float  # [N] of the reconstructed fa over the scored laps
    hover_throttle_start: float
    hover_throttle_end: float
    rms_after_skip: float  # [m] RMS of |p - p_d| over every t >= 5 s: the published figure
    lap_periodic_share: float  # of the error's mean square, the part that repeats each lap
    command_over_hover_mean: float  # T_sp / hover_throttle over the scored laps
    command_over_hover_peak: float  # its largest sample there
    limit_share: float  # of the scored samples, those at an actuator limit; NaN: unknown


def lap_boundaries(log: FlightLog, skip: float = SKIP) -> tuple[float, ...]:
    """Every time at or after ``skip`` [s] that ``p_d`` crosses the centre of its x swing
    moving +x (φ ≡ 0 mod 2π), linearly interpolated between samples."""
    x = log.p_d[:, 0]
    centre = 0.5 * (x.max() + x.min())  # the figure's x centre (0.25 m in Neural-Fly's)
    below, above = x[:-1] - centre, x[1:] - centre
    rising = np.flatnonzero((below < 0) & (above >= 0))
    # where the straight line between the two samples crosses the centre
    fraction = -below[rising] / (above[rising] - below[rising])
    times = log.t[rising] + fraction * (log.t[rising + 1] - log.t[rising])
    return tuple(float(time) for time in times if time >= skip)


def lap_window(log: FlightLog, skip: float = SKIP, laps: int | None = None) -> LapWindow:
    """The whole laps of ``log`` after ``skip`` [s] (the first ``laps`` of them if given)."""
    boundaries = [b for b in lap_boundaries(log, skip) if b <= log.t[-1]]
    available = len(boundaries) - 1
    if available < 1:
        raise ValueError(f"{log.source or 'a log'}: no whole lap of the figure-8 after "
                         f"{skip:g} s within its {log.t[-1]:.1f} s (a lap is 2π s, started "
                         "where p_d crosses its x centre moving +x): fly it longer")
    if laps is not None and not 1 <= laps <= available:
        raise ValueError(f"{log.source or 'a log'}: {laps} laps asked for; it holds 1 to "
                         f"{available} whole laps after {skip:g} s")
    count = available if laps is None else laps
    chosen = tuple(boundaries[:count + 1])
    return LapWindow(chosen[0], chosen[-1], count, chosen)


def lap_phase(t: NDArray, window: LapWindow) -> NDArray:
    """φ [rad] at ``t`` (within the window): 2π per lap, linear in time within each lap."""
    bounds = np.asarray(window.boundaries)
    lap = np.clip(np.searchsorted(bounds, t, side="right") - 1, 0, window.laps - 1)
    # the fraction of its lap a sample is through, each lap 2π
    return 2 * np.pi * (lap + (t - bounds[lap]) / (bounds[lap + 1] - bounds[lap]))


def central_difference(values: NDArray, t: NDArray) -> NDArray:
    """(x[k+1] - x[k-1]) / (t[k+1] - t[k-1]); NaN at the two ends."""
    derivative = np.full(values.shape, np.nan)
    span = (t[2:] - t[:-2]).reshape(-1, *([1] * (values.ndim - 1)))
    derivative[1:-1] = (values[2:] - values[:-2]) / span
    return derivative


def moving_average(values: NDArray, t: NDArray, span: float = SMOOTHING_SPAN) -> NDArray:
    """The centred mean of the samples within ±span/2 (2 round(span / 2 dt) + 1 samples);
    NaN where that window leaves the log (or holds a NaN)."""
    half = max(1, round(span / 2 / float(np.median(np.diff(t)))))
    width = 2 * half + 1
    smoothed = np.full(values.shape, np.nan)
    if len(values) >= width:
        kernel = np.ones(width) / width
        smoothed[half:-half] = np.convolve(values, kernel, mode="valid")
    return smoothed


def reconstruct_fa(log: FlightLog, gravity: float = GRAVITY) -> NDArray:
    """The residual force [N] (T, 3) from the logged fields; NaN at the two ends:
    the force the vehicle's acceleration needs, less the thrust the setpoint commands."""
    e3 = np.array([0.0, 0.0, 1.0])
    acceleration = central_difference(log.v, log.t)
    # the commanded thrust: T_sp / hover_throttle of the weight m g, along body z (R e3)
    thrust = (log.T_sp / log.hover_throttle)[:, None] * log.mass * gravity * log.R[:, :, 2]
    # fa = m (v̇ + g e3) - f R e3 (Newton: m v̇ = f R e3 - m g e3 + fa)
    return log.mass * (acceleration + gravity * e3) - thrust


def fa_reconstruction_rms(log: FlightLog, gravity: float = GRAVITY) -> AxisValues:
    """RMS [N] per axis of ``reconstruct_fa`` less the ``fa`` the log records."""
    if log.fa is None:
        raise ValueError(f"{log.source or 'a log'} records no fa to compare with")
    difference = (reconstruct_fa(log, gravity) - log.fa)[1:-1]
    return AxisValues.of(np.sqrt(np.mean(difference ** 2, axis=0)))


def fit_fa_z(log: FlightLog, window: LapWindow, fa: NDArray | None = None) -> FazFit:
    """``fa_z ≈ a a_z + b v_z + c`` over ``window``: a_z the central difference of the
    logged v_z, and fa_z (``fa``, else ``reconstruct_fa``), a_z and v_z each smoothed by
    the same centred moving average; least squares."""
    fa = reconstruct_fa(log) if fa is None else fa
    v_z = log.v[:, 2]
    series = [moving_average(values, log.t) for values in
              (fa[:, 2], central_difference(v_z, log.t), v_z)]
    force, acceleration, velocity = series
    kept = window.mask(log.t) & np.all(np.isfinite(np.column_stack(series)), axis=1)
    if kept.sum() < 4:
        raise ValueError(f"{log.source or 'a log'}: {kept.sum()} samples to fit fa_z over; "
                         "the fit needs 4 or more")
    design = np.column_stack([acceleration[kept], velocity[kept], np.ones(kept.sum())])
    (a, b, c), *_ = np.linalg.lstsq(design, force[kept], rcond=None)
    residual = force[kept] - design @ np.array([a, b, c])
    total = np.sum((force[kept] - force[kept].mean()) ** 2)
    r_squared = 1.0 - np.sum(residual ** 2) / total if total > 0 else float("nan")
    # a lag τ of the thrust: T ≈ T_c - τ Ṫ_c, so fa_z ≈ -τ Ṫ_c ≈ -m τ j_z; for z = z_c +
    # A sin 2t, j_z = -4 v_z, so fa_z ≈ 4 m τ v_z: b = 4 m τ
    tau = b / (VERTICAL_FREQUENCY ** 2 * log.mass)
    return FazFit(float(a), float(b), float(c), float(r_squared), float(tau), int(kept.sum()))


def harmonics(error: NDArray, t: NDArray, window: LapWindow) -> tuple[Harmonic, ...]:
    """The single-sided Fourier amplitudes of ``error`` (T, 3) over the window's whole laps
    at ``HARMONICS`` of the lap: least squares on a constant and cos kφ, sin kφ (orthogonal
    over whole laps, so these are the Fourier coefficients, exact for a sinusoid even when
    a lap is not a whole number of samples); amplitude sqrt(cos² + sin²) coefficients."""
    kept = window.mask(t)
    phase = lap_phase(t[kept], window)
    columns = [np.ones(kept.sum())]
    for k in HARMONICS:
        columns += [np.cos(k * phase), np.sin(k * phase)]
    coefficients, *_ = np.linalg.lstsq(np.column_stack(columns), error[kept], rcond=None)
    # c cos kφ + s sin kφ = A cos(kφ - θ): A = hypot(c, s), θ = atan2(s, c)
    return tuple(Harmonic(k, AxisValues.of(np.hypot(coefficients[1 + 2 * i],
                                                    coefficients[2 + 2 * i])),
                          AxisValues.of(np.arctan2(coefficients[2 + 2 * i],
                                                   coefficients[1 + 2 * i])))
                 for i, k in enumerate(HARMONICS))


def lap_periodic_share(error: NDArray, t: NDArray, window: LapWindow) -> float:
    """The share of the error's mean square over the window's laps that repeats every lap,
    by synchronous averaging: the lap's phase cut into ``PERIODIC_BINS`` equal bins, ē_b the
    mean error of every sample of every lap in bin b, and share = Σ |ē_b(i)|² / Σ |e_i|² over
    the samples. NaN for one lap. A bin is 2π / 64 wide, so the lap's harmonics 1-3 keep
    over 99 % of their power; noise that does not repeat leaks about bins / samples of its
    power into ē (2 % for 8 laps at 50 Hz)."""
    if window.laps < 2:
        return float("nan")
    kept = window.mask(t)
    phase, values = lap_phase(t[kept], window), error[kept]
    bins = np.minimum((np.mod(phase, 2 * np.pi) / (2 * np.pi) * PERIODIC_BINS).astype(int),
                      PERIODIC_BINS - 1)
    counts = np.bincount(bins, minlength=PERIODIC_BINS)
    means = np.stack([np.bincount(bins, values[:, axis], PERIODIC_BINS) for axis in range(3)],
                     axis=1) / np.maximum(counts, 1)[:, None]
    power = np.sum(values ** 2)
    return float(np.sum(means[bins] ** 2) / power) if power > 0 else float("nan")


def limit_samples(log: FlightLog) -> NDArray[np.bool_] | None:
    """Where ``log``'s actuators were at a limit: any motor's PWM at ``LIMIT_PWM`` or more
    (a real log), else its ``at_limit`` (a simulated one: any rotor at its limit in the
    step); None when the log says neither."""
    if log.pwm is not None:
        return np.any(log.pwm >= LIMIT_PWM, axis=1)
    if log.at_limit is not None:
        return log.at_limit > 0.5
    return None


def log_statistics(log: FlightLog, laps: int | None = None, skip: float = SKIP
                   ) -> LogStatistics:
    """``log``'s statistics over its whole laps after ``skip`` (the first ``laps``)."""
    window = lap_window(log, skip, laps)
    kept = window.mask(log.t)
    error = log.p - log.p_d
    size = error_statistics(error[kept])
    rms = np.array([size.rms.x, size.rms.y, size.rms.z])
    fa = reconstruct_fa(log)
    start = log.t < log.t[0] + HOVER_SPAN
    end = log.t > log.t[-1] - HOVER_SPAN
    settled = log.t >= skip
    command = (log.T_sp / log.hover_throttle)[kept]  # the collective over the hover command
    limits = limit_samples(log)
    return LogStatistics(
        window=window, rms=size.rms, rms_total=size.rms_total,
        mean=AxisValues.of(error[kept].mean(axis=0)),
        z_share=z_share(rms),
        harmonics=harmonics(error, log.t, window), fa_z_fit=fit_fa_z(log, window, fa),
        mean_fa_x=float(np.nanmean(fa[kept, 0])),
        hover_throttle_start=float(log.hover_throttle[start].mean()),
        hover_throttle_end=float(log.hover_throttle[end].mean()),
        rms_after_skip=float(np.sqrt(np.mean(np.sum(error[settled] ** 2, axis=1)))),
        lap_periodic_share=lap_periodic_share(error, log.t, window),
        command_over_hover_mean=float(command.mean()),
        command_over_hover_peak=float(command.max()),
        limit_share=float("nan") if limits is None else float(limits[kept].mean()))


def common_laps(logs: list[FlightLog], skip: float = SKIP) -> int:
    """The most whole laps after ``skip`` that every one of ``logs`` holds."""
    return min(lap_window(log, skip).laps for log in logs)
