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
- attitude error: from mocap ``e_w = R̂ ½ vee(R̂ᵀR_m - R_mᵀR̂)`` (R̂ of the fix's time);
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
def _rotation(state, column):
    return (state[column], state[column + 1], state[column + 2], state[column + 3],
            state[column + 4], state[column + 5], state[column + 6], state[column + 7],
            state[column + 8])


@njit(cache=True, inline="always")
def _store_rotation(state, column, R):
    for k in range(9):
        state[column + k] = R[k]


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
    per episode); ``gains``: ω_p, ω_R, ω_v [rad/s]."""
    pose_delays, imu_delay, lag = delays
    position_bandwidth, attitude_bandwidth, velocity_bandwidth = gains
    depth, length = ring.shape[0], history.shape[0]
    fix_period = period * dt
    for j in range(start, stop):
        i = indices[j]
        step = step_count[i]
        e = estimate[i]
        imu = ring[max(step - imu_delay, 0) % depth, i]
        before = ring[max(step - imu_delay - 1, 0) % depth, i]  # the IMU's reading before
        gyro = (0.5 * (imu[GYRO] + before[GYRO]) - e[BG],
                0.5 * (imu[GYRO + 1] + before[GYRO + 1]) - e[BG + 1],
                0.5 * (imu[GYRO + 2] + before[GYRO + 2]) - e[BG + 2])
        R = _rotation(e, R_)
        middle = R  # the attitude half way through the step, for its mean specific force
        if predict:
            half = (0.5 * gyro[0] * dt, 0.5 * gyro[1] * dt, 0.5 * gyro[2] * dt)
            middle = mat_mul_tuple(R, exp_tuple(half))
            R = mat_mul_tuple(middle, exp_tuple(half))
        specific = mat_vec_tuple(middle, (imu[ACCEL] - e[BA], imu[ACCEL + 1] - e[BA + 1],
                                   imu[ACCEL + 2] - e[BA + 2]))
        if predict:
            for k in range(3):
                a = specific[k] - (gravity if k == 2 else 0.0)
                e[P + k] += e[V + k] * dt + 0.5 * a * dt * dt
                e[V + k] += a * dt
            _store_rotation(e, R_, R)
        newest = history[step % length, i]  # this step's entry, over the oldest one
        for k in range(15):
            newest[k] = e[k]
        for k in range(3):
            newest[HS + k] = specific[k]
        taken = step - pose_delays[i]
        if taken >= 0 and taken % period == 0:
            fix = ring[taken % depth, i]
            then = history[(step - lag) % length, i]
            _correct(e, fix, then, history, i, step, lag, period, kind, fix_period,
                     position_bandwidth, attitude_bandwidth, velocity_bandwidth, gravity)
        for k in range(3):
            out_position[i, k] = e[P + k]
            out_velocity[i, k] = e[V + k]
            out_rates[i, k] = imu[GYRO + k] - e[BG + k]
            for c in range(3):
                out_rotation[i, k, c] = e[R_ + 3 * k + c]


@njit(cache=True, inline="always")
def _correct(e, fix, then, history, i, step, lag, period, kind, T, position_bandwidth,
             attitude_bandwidth, velocity_bandwidth, gravity):
    """Apply one pose fix to the estimate ``e`` and to the whole history."""
    length = history.shape[0]
    R_then = _rotation(then, HR)
    R = _rotation(e, R_)
    y = (fix[POSITION] - then[HP], fix[POSITION + 1] - then[HP + 1],
         fix[POSITION + 2] - then[HP + 2])
    w = position_bandwidth
    # tuples, not lists: a list is a heap allocation per call
    shift_p = (3.0 * w * T * y[0], 3.0 * w * T * y[1], 3.0 * w * T * y[2])
    shift_v = (3.0 * w * w * T * y[0], 3.0 * w * w * T * y[1], 3.0 * w * w * T * y[2])
    bias_step = mat_vec_tuple(transpose_tuple(R), y)
    for k in range(3):
        e[BA + k] -= w * w * w * T * bias_step[k]
    if kind == 0:  # mocap: the attitude itself
        Rm = (fix[ROTATION], fix[ROTATION + 1], fix[ROTATION + 2], fix[ROTATION + 3],
              fix[ROTATION + 4], fix[ROTATION + 5], fix[ROTATION + 6], fix[ROTATION + 7],
              fix[ROTATION + 8])
        # A = R̂ᵀ R_m; e = ½ vee(A - Aᵀ)
        a21 = R_then[2] * Rm[1] + R_then[5] * Rm[4] + R_then[8] * Rm[7]
        a12 = R_then[1] * Rm[2] + R_then[4] * Rm[5] + R_then[7] * Rm[8]
        a02 = R_then[0] * Rm[2] + R_then[3] * Rm[5] + R_then[6] * Rm[8]
        a20 = R_then[2] * Rm[0] + R_then[5] * Rm[3] + R_then[8] * Rm[6]
        a10 = R_then[1] * Rm[0] + R_then[4] * Rm[3] + R_then[7] * Rm[6]
        a01 = R_then[0] * Rm[1] + R_then[3] * Rm[4] + R_then[6] * Rm[7]
        # the error, a rotation vector in the body frame of then, turned into the world's
        world = mat_vec_tuple(R_then, (0.5 * (a21 - a12), 0.5 * (a02 - a20), 0.5 * (a10 - a01)))
    else:  # GNSS: velocity, heading and the levelling against its acceleration
        shift_v = (shift_v[0] + velocity_bandwidth * T * (fix[VELOCITY] - then[HV]),
                   shift_v[1] + velocity_bandwidth * T * (fix[VELOCITY + 1] - then[HV + 1]),
                   shift_v[2] + velocity_bandwidth * T * (fix[VELOCITY + 2] - then[HV + 2]))
        heading_error = wrap_angle(fix[HEADING] - heading_of(R_then))
        levelling = [0.0, 0.0, 0.0]
        if e[HAS_LAST_V] > 0.0:
            measured = [0.0, 0.0, 0.0]  # the IMU's mean world specific force over the fix
            for j in range(period):
                entry = history[(step - lag - j) % length, i]
                for k in range(3):
                    measured[k] += entry[HS + k] / period
            shown = [(fix[VELOCITY + k] - e[LAST_V + k]) / T for k in range(3)]
            shown[2] += gravity
            shown_norm = math.sqrt(shown[0] ** 2 + shown[1] ** 2 + shown[2] ** 2)
            norm = shown_norm * math.sqrt(measured[0] ** 2 + measured[1] ** 2
                                          + measured[2] ** 2)
            # trusted fully at 1 g of specific force, not at all below 0.5 g or above 1.5 g:
            # far from 1 g (a climb, a cut of thrust) the direction says little
            weight = min(max(1.0 - 2.0 * abs(shown_norm / gravity - 1.0), 0.0), 1.0)
            if norm > 0.0:
                levelling[0] = weight * (measured[1] * shown[2] - measured[2] * shown[1]) / norm
                levelling[1] = weight * (measured[2] * shown[0] - measured[0] * shown[2]) / norm
                levelling[2] = weight * (measured[0] * shown[1] - measured[1] * shown[0]) / norm
        for k in range(3):
            e[LAST_V + k] = fix[VELOCITY + k]
        e[HAS_LAST_V] = 1.0
        world = (levelling[0], levelling[1], levelling[2] + heading_error)
    # applied in the world frame, R̂ ← exp(ω_R T e_w) R̂, to the estimate and its history
    # alike (the attitude of then and now differ by the lag's rotation)
    turn = exp_tuple((attitude_bandwidth * T * world[0], attitude_bandwidth * T * world[1],
                      attitude_bandwidth * T * world[2]))
    # in the body frame now, where the gyroscope's bias lives
    error = mat_vec_tuple(transpose_tuple(R), world)
    integral = 0.25 * attitude_bandwidth * attitude_bandwidth * T
    for k in range(3):
        e[BG + k] -= integral * error[k]
    _store_rotation(e, R_, mat_mul_tuple(turn, R))
    for k in range(3):
        e[P + k] += shift_p[k]
        e[V + k] += shift_v[k]
    for h in range(length):  # the history moves with the estimate
        entry = history[h, i]
        for k in range(3):
            entry[HP + k] += shift_p[k]
            entry[HV + k] += shift_v[k]
        _store_rotation(entry, HR, mat_mul_tuple(turn, _rotation(entry, HR)))
        specific = mat_vec_tuple(turn, (entry[HS], entry[HS + 1], entry[HS + 2]))
        for k in range(3):
            entry[HS + k] = specific[k]
