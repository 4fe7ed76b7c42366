"""The state estimator: a complementary filter on the IMU, corrected by each pose fix.

Every control step, for every vehicle, from its IMU's newest readings (gyroscope ω_m, the
rate now, and accelerometer f_m, the step's mean specific force, with the estimated
biases b̂_g, b̂_a taken off):

- attitude: ``R̂ ← R̂ exp((ω̄_m - b̂_g) dt)`` with ``ω̄_m`` the mean of the gyroscope's
  last two readings (the trapezoid: integrating the newest alone leaves an error of
  Ω̇ dt²/2 a step, 5 mrad on the wind helix at 100 Hz); rates ``Ω̂ = ω_m - b̂_g``;
- position and velocity: ``a = R̂_½ (f_m - b̂_a) - g e3`` with ``R̂_½`` the attitude half
  way through the step, ``p̂ ← p̂ + v̂ dt + a dt²/2``, ``v̂ ← v̂ + a dt``.

A pose fix taken L steps before the estimate's time is compared with the estimate of that
time (kept in a short history; the correction then moves the whole history, so the next
fix compares against corrected values), with gains of a bandwidth times the fix period T:

- position innovation ``y = p_m - p̂(t - L)``: ``p̂ += 3 ω_p T y``, ``v̂ += 3 ω_p² T y``,
  ``b̂_a -= ω_p³ T R̂ᵀ y`` (three poles at -ω_p, Mahony-style bias feedback);
- GNSS velocity ``v̂ += ω_v T (v_m - v̂(t - L))``;
- attitude error: from mocap ``e_w = R̂ ½ vee(R̂ᵀR_m - R_mᵀR̂)`` (R̂ of the fix's time;
  none from ``mocap-position``, one marker's fix, where the attitude is the gyroscope's);
  from GNSS with a compass ``e_w = e_tilt + δψ e3``, the heading error δψ and
  ``e_tilt = ŝ × s / (|ŝ| |s|)``, ``ŝ`` the IMU's mean world specific force over the fix
  interval and ``s = Δv_m / T + g e3`` what the receiver's velocities show (the
  acceleration-compensated levelling of GPS-aided AHRSs, Premerlani & Bizard, "Direction
  Cosine Matrix IMU: Theory", 2009), weighted by ``clip(1 - 2 | |s| / g - 1 |, 0, 1)``
  (no levelling far from 1 g); then, with ``e_w`` the error in the world frame,
  ``R̂ ← exp(ω_R T e_w) R̂`` and ``b̂_g -= (ω_R² / 4) T R̂ᵀ e_w`` (Mahony, Hamel,
  Pflimlin 2008, IEEE TAC 53(5): a proportional-integral correction, here with a double
  pole at -ω_R / 2). The history's attitudes and specific forces turn with the estimate.
"""

import math
from typing import NamedTuple

from numba import njit

from quad_dob_env.sensing.sensing_pass import (
    ACCEL,
    GYRO,
    HEADING,
    POSITION,
    ROTATION,
    VELOCITY,
    heading_of,
    wrap_angle,
)
from quad_dob_env.so3 import exp_tuple, mat_mul_tuple, mat_vec_tuple, transpose_tuple

# estimator state columns (``ESTIMATE_WIDTH``)
P, V, R_, BG, BA, LAST_V, HAS_LAST_V = 0, 3, 6, 15, 18, 21, 24
# history columns (``HISTORY_WIDTH``): position, velocity, rotation, specific force
HP, HV, HR, HS = 0, 3, 6, 15


@njit(cache=True, inline="always")
def _row_rotation(table, i, column):
    """A row-major rotation from columns ``column..column+8`` of row i of (N, width)."""
    return (table[i, column], table[i, column + 1], table[i, column + 2],
            table[i, column + 3], table[i, column + 4], table[i, column + 5],
            table[i, column + 6], table[i, column + 7], table[i, column + 8])


@njit(cache=True, inline="always")
def _store_row_rotation(table, i, column, R):
    """Write ``R`` into columns ``column..column+8`` of row i, straight-line (a loop in an
    inlined function with an array counts a reference in and out at every call)."""
    table[i, column], table[i, column + 1], table[i, column + 2] = R[0], R[1], R[2]
    table[i, column + 3], table[i, column + 4], table[i, column + 5] = R[3], R[4], R[5]
    table[i, column + 6], table[i, column + 7], table[i, column + 8] = R[6], R[7], R[8]


@njit(cache=True, inline="always")
def _entry_rotation(lines, slot, i, column):
    """``_row_rotation`` of slot ``slot`` of a (depth, N, width) line."""
    return (lines[slot, i, column], lines[slot, i, column + 1], lines[slot, i, column + 2],
            lines[slot, i, column + 3], lines[slot, i, column + 4],
            lines[slot, i, column + 5], lines[slot, i, column + 6],
            lines[slot, i, column + 7], lines[slot, i, column + 8])


@njit(cache=True, inline="always")
def _store_entry_rotation(lines, slot, i, column, R):
    """``_store_row_rotation`` into slot ``slot`` of a (depth, N, width) line."""
    lines[slot, i, column], lines[slot, i, column + 1] = R[0], R[1]
    lines[slot, i, column + 2], lines[slot, i, column + 3] = R[2], R[3]
    lines[slot, i, column + 4], lines[slot, i, column + 5] = R[4], R[5]
    lines[slot, i, column + 6], lines[slot, i, column + 7] = R[6], R[7]
    lines[slot, i, column + 8] = R[8]


@njit(cache=True, inline="always")
def _entry_vector(lines, slot, i, column):
    return (lines[slot, i, column], lines[slot, i, column + 1], lines[slot, i, column + 2])


@njit(cache=True)
def start_estimates_kernel(indices, position, velocity, rotation, estimate, history):
    """At a reset the filter starts on the true state (it has converged on the pad before
    take-off) with zero bias estimates; its history is that state."""
    for i in indices:
        for k in range(3):
            estimate[i, P + k] = position[i, k]
            estimate[i, V + k] = velocity[i, k]
        for r in range(3):
            for c in range(3):
                estimate[i, R_ + 3 * r + c] = rotation[i, r, c]
        for k in range(BG, estimate.shape[1]):
            estimate[i, k] = 0.0
        for h in range(history.shape[0]):
            for k in range(15):
                history[h, i, k] = estimate[i, k]
            history[h, i, HS], history[h, i, HS + 1], history[h, i, HS + 2] = 0.0, 0.0, 0.0


@njit(cache=True, nogil=True)
def estimate_kernel(start, stop, indices, step_count, predict, ring, delays, period, kind,
                    gains, dt, gravity, estimate, history, out_position, out_velocity,
                    out_rotation, out_rates):
    """One step of the filter for vehicles ``indices[start:stop]`` (module docstring), then
    the estimate into the ``out_`` arrays (``predict`` False at a reset: the estimate stays
    where ``start_estimates_kernel`` put it). ``delays``: each vehicle's pose delay (N,)
    and the IMU's delay in steps, and the lag the filter is told the fix has over the IMU
    (the two's difference, but for an unmodelled pose latency, which each vehicle may draw
    per episode); ``gains``: ω_p, ω_R, ω_v [rad/s].

    Every array is read and written by its indices, never through a row's view: a view
    counts a reference in and out (an atomic add on a line both cores share), ten a
    vehicle before 2026-12-06."""
    pose_delays, imu_delay, lag = delays
    position_bandwidth, attitude_bandwidth, velocity_bandwidth = gains
    depth, length = ring.shape[0], history.shape[0]
    fix_period = period * dt
    e = estimate
    for j in range(start, stop):
        i = indices[j]
        step = step_count[i]
        now = max(step - imu_delay, 0) % depth  # the IMU's newest reading's slot
        last = max(step - imu_delay - 1, 0) % depth  # and the one before
        gyro = (0.5 * (ring[now, i, GYRO] + ring[last, i, GYRO]) - e[i, BG],
                0.5 * (ring[now, i, GYRO + 1] + ring[last, i, GYRO + 1]) - e[i, BG + 1],
                0.5 * (ring[now, i, GYRO + 2] + ring[last, i, GYRO + 2]) - e[i, BG + 2])
        R = _row_rotation(e, i, R_)
        middle = R  # the attitude half way through the step, for its mean specific force
        if predict:
            half = (0.5 * gyro[0] * dt, 0.5 * gyro[1] * dt, 0.5 * gyro[2] * dt)
            middle = mat_mul_tuple(R, exp_tuple(half))
            R = mat_mul_tuple(middle, exp_tuple(half))
        specific = mat_vec_tuple(middle, (ring[now, i, ACCEL] - e[i, BA],
                                          ring[now, i, ACCEL + 1] - e[i, BA + 1],
                                          ring[now, i, ACCEL + 2] - e[i, BA + 2]))
        if predict:
            for k in range(3):
                a = specific[k] - (gravity if k == 2 else 0.0)
                e[i, P + k] += e[i, V + k] * dt + 0.5 * a * dt * dt
                e[i, V + k] += a * dt
            _store_row_rotation(e, i, R_, R)
        newest = step % length  # this step's entry, over the oldest one
        for k in range(15):
            history[newest, i, k] = e[i, k]
        for k in range(3):
            history[newest, i, HS + k] = specific[k]
        taken = step - pose_delays[i]
        if taken >= 0 and taken % period == 0:
            fix, then = taken % depth, (step - lag) % length
            measured = (0.0, 0.0, 0.0)  # the IMU's mean world specific force over the fix
            if kind == 1 and e[i, HAS_LAST_V] > 0.0:
                m0, m1, m2 = 0.0, 0.0, 0.0
                for back in range(period):
                    entry = (step - lag - back) % length
                    m0 += history[entry, i, HS] / period
                    m1 += history[entry, i, HS + 1] / period
                    m2 += history[entry, i, HS + 2] / period
                measured = (m0, m1, m2)
            fixed = _correction(
                _entry_vector(ring, fix, i, POSITION), _entry_rotation(ring, fix, i, ROTATION),
                _entry_vector(ring, fix, i, VELOCITY), ring[fix, i, HEADING],
                _entry_vector(history, then, i, HP), _entry_rotation(history, then, i, HR),
                _entry_vector(history, then, i, HV), _row_rotation(e, i, R_),
                (e[i, LAST_V], e[i, LAST_V + 1], e[i, LAST_V + 2]), e[i, HAS_LAST_V] > 0.0,
                measured, kind, fix_period, position_bandwidth, attitude_bandwidth,
                velocity_bandwidth, gravity)
            shift_p, shift_v, turn = fixed.shift_p, fixed.shift_v, fixed.turn
            for k in range(3):
                e[i, BA + k] -= fixed.accelerometer_bias_step[k]
            if kind == 1:
                for k in range(3):
                    e[i, LAST_V + k] = ring[fix, i, VELOCITY + k]
                e[i, HAS_LAST_V] = 1.0
            for k in range(3):
                e[i, BG + k] -= fixed.gyroscope_bias_step[k]
            _store_row_rotation(e, i, R_, fixed.rotation)
            for k in range(3):
                e[i, P + k] += shift_p[k]
                e[i, V + k] += shift_v[k]
            for h in range(length):  # the history moves with the estimate
                for k in range(3):
                    history[h, i, HP + k] += shift_p[k]
                    history[h, i, HV + k] += shift_v[k]
                _store_entry_rotation(history, h, i, HR,
                                      mat_mul_tuple(turn, _entry_rotation(history, h, i, HR)))
                turned = mat_vec_tuple(turn, _entry_vector(history, h, i, HS))
                for k in range(3):
                    history[h, i, HS + k] = turned[k]
        for k in range(3):
            out_position[i, k] = e[i, P + k]
            out_velocity[i, k] = e[i, V + k]
            out_rates[i, k] = ring[now, i, GYRO + k] - e[i, BG + k]
            for c in range(3):
                out_rotation[i, k, c] = e[i, R_ + 3 * k + c]


class Correction(NamedTuple):
    """What one pose fix does to a vehicle's estimate (``_correction``): every history
    entry and the estimate shift by ``shift_p``, ``shift_v`` and turn by ``turn``; the
    biases' estimates lose their steps; the attitude becomes ``rotation``."""

    shift_p: tuple
    shift_v: tuple
    turn: tuple  # row-major, applied in the world frame
    accelerometer_bias_step: tuple
    gyroscope_bias_step: tuple
    rotation: tuple  # the estimate's new attitude, row-major


@njit(cache=True, inline="always")
def _correction(fix_position, fix_rotation, fix_velocity, fix_heading, then_position,
                then_rotation, then_velocity, R, last_velocity, has_last, measured, kind, T,
                position_bandwidth, attitude_bandwidth, velocity_bandwidth, gravity):
    """One pose fix's ``Correction``, numbers in: the fix's reading, the history's entry of
    its time (``then_*``), the estimate's attitude now ``R``, the last GNSS velocity and
    whether there is one, and ``measured``, the IMU's mean world specific force over the
    fix interval (GNSS levelling only)."""
    R_then = then_rotation
    y = (fix_position[0] - then_position[0], fix_position[1] - then_position[1],
         fix_position[2] - then_position[2])
    w = position_bandwidth
    shift_p = (3.0 * w * T * y[0], 3.0 * w * T * y[1], 3.0 * w * T * y[2])
    shift_v = (3.0 * w * w * T * y[0], 3.0 * w * w * T * y[1], 3.0 * w * w * T * y[2])
    bias_step = mat_vec_tuple(transpose_tuple(R), y)
    accelerometer = (w * w * w * T * bias_step[0], w * w * w * T * bias_step[1],
                     w * w * w * T * bias_step[2])
    if kind == 0:  # mocap: the attitude itself
        Rm = fix_rotation
        # A = R̂ᵀ R_m; e = ½ vee(A - Aᵀ)
        a21 = R_then[2] * Rm[1] + R_then[5] * Rm[4] + R_then[8] * Rm[7]
        a12 = R_then[1] * Rm[2] + R_then[4] * Rm[5] + R_then[7] * Rm[8]
        a02 = R_then[0] * Rm[2] + R_then[3] * Rm[5] + R_then[6] * Rm[8]
        a20 = R_then[2] * Rm[0] + R_then[5] * Rm[3] + R_then[8] * Rm[6]
        a10 = R_then[1] * Rm[0] + R_then[4] * Rm[3] + R_then[7] * Rm[6]
        a01 = R_then[0] * Rm[1] + R_then[3] * Rm[4] + R_then[6] * Rm[7]
        # the error, a rotation vector in the body frame of then, turned into the world's
        world = mat_vec_tuple(R_then, (0.5 * (a21 - a12), 0.5 * (a02 - a20), 0.5 * (a10 - a01)))
    elif kind == 2:  # mocap of one marker: the position alone, the attitude left to the gyro
        world = (0.0, 0.0, 0.0)
    else:  # GNSS: velocity, heading and the levelling against its acceleration
        shift_v = (shift_v[0] + velocity_bandwidth * T * (fix_velocity[0] - then_velocity[0]),
                   shift_v[1] + velocity_bandwidth * T * (fix_velocity[1] - then_velocity[1]),
                   shift_v[2] + velocity_bandwidth * T * (fix_velocity[2] - then_velocity[2]))
        heading_error = wrap_angle(fix_heading - heading_of(R_then))
        levelling = (0.0, 0.0, 0.0)
        if has_last:
            shown = ((fix_velocity[0] - last_velocity[0]) / T,
                     (fix_velocity[1] - last_velocity[1]) / T,
                     (fix_velocity[2] - last_velocity[2]) / T + gravity)
            shown_norm = math.sqrt(shown[0] ** 2 + shown[1] ** 2 + shown[2] ** 2)
            norm = shown_norm * math.sqrt(measured[0] ** 2 + measured[1] ** 2
                                          + measured[2] ** 2)
            # trusted fully at 1 g of specific force, not at all below 0.5 g or above 1.5 g:
            # far from 1 g (a climb, a cut of thrust) the direction says little
            weight = min(max(1.0 - 2.0 * abs(shown_norm / gravity - 1.0), 0.0), 1.0)
            if norm > 0.0:
                levelling = (weight * (measured[1] * shown[2] - measured[2] * shown[1]) / norm,
                             weight * (measured[2] * shown[0] - measured[0] * shown[2]) / norm,
                             weight * (measured[0] * shown[1] - measured[1] * shown[0]) / norm)
        world = (levelling[0], levelling[1], levelling[2] + heading_error)
    # applied in the world frame, R̂ ← exp(ω_R T e_w) R̂, to the estimate and its history
    # alike (the attitude of then and now differ by the lag's rotation)
    turn = exp_tuple((attitude_bandwidth * T * world[0], attitude_bandwidth * T * world[1],
                      attitude_bandwidth * T * world[2]))
    # in the body frame now, where the gyroscope's bias lives
    error = mat_vec_tuple(transpose_tuple(R), world)
    integral = 0.25 * attitude_bandwidth * attitude_bandwidth * T
    return Correction(shift_p, shift_v, turn, accelerometer,
                      (integral * error[0], integral * error[1], integral * error[2]),
                      mat_mul_tuple(turn, R))
