"""The compiled sensing pass: every vehicle's readings, their delay lines and the state
estimator, once per control step (``SensingStage`` calls it for the whole batch).

A reading row holds, in this order: position (3), rotation (9, row-major), velocity (3),
compass heading (1), gyroscope (3), accelerometer (3), rotor speeds (4). Each sensor draws
its noise from its own key (``quad_dob_env.rng``: the n-th draw of a key depends on the
key and n alone), so one sensor's settings never move another's noise, nor any other
random draw of the flight.

``take_readings_kernel`` reads its records by name: the states the pose fix sees
(``PoseState``: now, and where the step passed its latency), the truth (``TrueState``),
each source's settings (``PoseSettings``, ``ImuSettings``, ``RotorSettings``,
``StateNoise``, ``ToneSettings``) and the sensors' own arrays (``ReadingLines``); passed
from Python as
plain tuples (numba types a named tuple on a slower path every call) and rebuilt in its
first lines.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.rng import gaussian_pair
from quad_dob_env.so3 import exp_tuple, mat_mul_tuple, matrix_at

READING_WIDTH = 26
POSITION, ROTATION, VELOCITY, HEADING, GYRO, ACCEL, ROTORS = 0, 3, 12, 15, 16, 19, 22
# estimator state per vehicle: position, velocity, rotation, gyroscope bias, accelerometer
# bias (body), the last GNSS velocity fix, whether there is one
ESTIMATE_WIDTH = 25
# estimator history per vehicle and step: position, velocity, rotation, world specific force
HISTORY_WIDTH = 18
# keys per vehicle: pose, IMU, rotors, state noise, initial biases
KEYS = 5
POSE_KEY, IMU_KEY, ROTOR_KEY, STATE_KEY, BIAS_KEY = range(KEYS)


class PoseState(NamedTuple):
    """The state the pose fix reads: now, or where the step passed the pose's latency."""

    position: NDArray  # (N, 3)
    velocity: NDArray  # (N, 3)
    rotation: NDArray  # (N, 3, 3)


class TrueState(NamedTuple):
    """The truth the sensors read: the state now, what the physics applied over the step,
    and what the rotors give at a reset (they start at hover; nothing is applied yet)."""

    position: NDArray  # (N, 3)
    velocity: NDArray  # (N, 3)
    rotation: NDArray  # (N, 3, 3)
    angular_velocity: NDArray  # (N, 3)
    thrust: NDArray  # (N,) applied thrust, the step's mean
    force: NDArray  # (N, 3) every non-gravity force but the thrust, world frame
    mass: NDArray  # (N,)
    rotor_thrusts: NDArray  # (N, 4)
    hover_thrust: float  # at a reset
    hover_rotor_thrusts: NDArray  # (4,) at a reset


class PoseSettings(NamedTuple):
    """The pose fix's settings (the defaults: no pose fix, nothing drawn); where each
    vehicle's is taken within a step is its own (an unmodelled latency drawn per episode)."""

    tick: NDArray  # (N,) int64 the tick after which the fix is taken; 0: the step's end
    kind: int = 0  # its index in POSE_KINDS: 0 mocap, 1 gnss, 2 mocap-position
    period: int = 1  # a fix every so many steps
    position_std: float = 0.0  # [m], horizontal
    vertical_std: float = 0.0  # [m]
    attitude_std: float = 0.0  # [rad]
    velocity_std: float = 0.0  # [m/s]
    heading_std: float = 0.0  # [rad]


class ImuSettings(NamedTuple):
    """The IMU's settings per control step (the defaults: none); its white noise is each
    vehicle's own (the rotors' vibration in it is drawn per episode)."""

    gyroscope_std: NDArray  # (N,) white noise per sample [rad/s], vibration included
    accelerometer_std: NDArray  # (N,) [m/s²]
    gyroscope_walk: float = 0.0  # the bias's random walk per step
    accelerometer_walk: float = 0.0
    gyroscope_initial_bias: float = 0.0  # the std of a new episode's bias
    accelerometer_initial_bias: float = 0.0


class RotorSettings(NamedTuple):
    """The rotor-speed telemetry's settings."""

    speed_std: float  # [rad/s]
    thrust_coefficient: float  # k_F, T = k_F ω²


class StateNoise(NamedTuple):
    """``SensorNoise``'s noise on the state itself (the defaults: none)."""

    position_std: float = 0.0
    velocity_std: float = 0.0
    attitude_std: float = 0.0
    rate_std: float = 0.0


class ToneSettings(NamedTuple):
    """The rotors' vibration tones on the accelerometer (``quad_dob_env.sensing.vibration``;
    the defaults: none): each rotor's amplitudes, each vehicle's own (its vibration scale
    drawn per episode), and what the IMU chain leaves of a tone, tabulated by frequency."""

    rotor_amplitude: NDArray  # (N,) a rotor's tone at its rotation frequency [m/s²], x and y
    blade_amplitude: NDArray  # (N,) a rotor's tone at the blade-pass frequency [m/s²], z
    gains: NDArray  # (rows, 2) the chain's gain G(f), real and imaginary, every table_step Hz
    table_step: float = 1.0  # [Hz]
    blades: int = 2
    dt: float = 0.0  # [s] between readings: each rotor's angle advances ω dt
    on: bool = False


class ReadingLines(NamedTuple):
    """The sensors' own arrays: each vehicle's keys and true IMU biases, the delay line of
    readings, and each rotor's angle (where its vibration tones are)."""

    keys: NDArray  # (N, KEYS) uint64
    true_bias: NDArray  # (N, 6) gyroscope, accelerometer
    ring: NDArray  # (depth, N, READING_WIDTH)
    rotor_angle: NDArray  # (N, 4) [rad], in [0, 2π)


@njit(cache=True, inline="always")
def _normals(key, step, count, out):
    """``count`` (even) standard normals for a key's ``step``-th reading."""
    for j in range(count // 2):
        out[2 * j], out[2 * j + 1] = gaussian_pair(key, 8 * step + j)


@njit(cache=True, inline="always")
def heading_of(R):
    """The heading of body x projected on the level plane [rad]; R row-major."""
    return math.atan2(R[3], R[0])


@njit(cache=True, inline="always")
def wrap_angle(angle):
    """``angle`` in [-π, π)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@njit(cache=True, inline="always")
def specific_force_vehicle(i, thrust, force, rotation, mass):
    """What an ideal accelerometer reads [m/s², body]: (f e3 + Rᵀ d) / m, the
    acceleration less gravity (d: every non-gravity force but the thrust, world frame).
    A tuple, not a list: a list is a heap allocation per call."""
    return (_body_force(i, 0, force, rotation) / mass[i],
            _body_force(i, 1, force, rotation) / mass[i],
            _body_force(i, 2, force, rotation) / mass[i] + thrust[i] / mass[i])


@njit(cache=True, inline="always")
def _body_force(i, k, force, rotation):
    """Body axis k of the world force d: (Rᵀ d)_k, summed in the order j = 0, 1, 2."""
    return (0.0 + rotation[i, 0, k] * force[i, 0] + rotation[i, 1, k] * force[i, 1]
            + rotation[i, 2, k] * force[i, 2])


@njit(cache=True, inline="always")
def rotor_speed(rotor_thrust, thrust_coefficient):
    """A rotor's speed [rad/s] from its thrust, T = k_F ω²."""
    return math.sqrt(max(rotor_thrust, 0.0) / thrust_coefficient)


@njit(cache=True, inline="always")
def _tabulated_gain(frequency, gains, table_step):
    """The chain's gain G(f) from its table, linear between rows (its last row above)."""
    x = frequency / table_step
    last = gains.shape[0] - 1
    k = min(int(x), last - 1)
    w = min(x - k, 1.0)
    return ((1.0 - w) * gains[k, 0] + w * gains[k + 1, 0],
            (1.0 - w) * gains[k, 1] + w * gains[k + 1, 1])


@njit(cache=True, inline="always")
def vibration_tones(i, angle, speeds, tones):
    """Vehicle ``i``'s tones on the accelerometer [m/s², body] with its rotors at ``angle``
    turning at ``speeds`` [rad/s]: per rotor ``a |G(f)| (cos, sin)(θ + arg G(f))`` in x and
    y at f = ω/2π and ``b |G(Bf)| sin(Bθ + arg G(Bf))`` in z (``sensing.vibration``)."""
    ax = ay = az = 0.0
    a, b = tones.rotor_amplitude[i], tones.blade_amplitude[i]
    for r in range(4):
        frequency = speeds[r] / (2.0 * math.pi)
        c, s = math.cos(angle[r]), math.sin(angle[r])
        gr, gi = _tabulated_gain(frequency, tones.gains, tones.table_step)
        # a G e^{jθ}: its real part along x, its imaginary part along y
        ax += a * (gr * c - gi * s)
        ay += a * (gr * s + gi * c)
        cb, sb = c, s  # e^{jBθ} by repeated products
        for _ in range(tones.blades - 1):
            cb, sb = cb * c - sb * s, cb * s + sb * c
        gr, gi = _tabulated_gain(tones.blades * frequency, tones.gains, tones.table_step)
        az += b * (gr * sb + gi * cb)
    return ax, ay, az


@njit(cache=True, nogil=True)
def take_readings_kernel(start, stop, indices, step_count, pose_now, pose_seen, truth, pose,
                         imu, rotors, state_noise, tones, lines, reset):
    """The readings of vehicles ``indices[start:stop]`` of their true state now, into each
    delay line's slot ``step % depth`` (at a reset, into every slot: no older readings
    exist). A source whose standard deviations are all zero draws nothing: its reading is
    the same, and no other source's noise depends on it.

    The pose fix reads ``pose_seen`` (a ``PoseState``: where the step passed the pose's
    latency on the physics grid, after the vehicle's own ``pose.tick``), or ``pose_now``
    where that tick is 0 and at a reset (nothing flown yet); the gyroscope reads the body
    rate now; the accelerometer the specific force of the step (its mean
    thrust, with the drag and disturbance at its end; ``truth`` a ``TrueState``). At a reset
    nothing is applied yet and the rotors turn at hover: the readings are ``hover_thrust``'s
    and ``hover_rotor_thrusts``'. Their white noise has the std density / √dt, the
    density's over the step.

    ``pose`` a ``PoseSettings``, ``imu`` an ``ImuSettings``, ``rotors`` a ``RotorSettings``,
    ``state_noise`` a ``StateNoise`` (``SensorNoise``'s mode has no IMU noise, biases nor
    estimator: ``imu`` is all zeros), ``tones`` a ``ToneSettings`` (its rotor angles start
    at a reset at phases drawn from the rotors' key, and advance by the rotors' speed over
    each step), ``lines`` the ``ReadingLines``; each passed as a plain tuple."""
    now, seen = PoseState(*pose_now), PoseState(*pose_seen)
    truth, lines = TrueState(*truth), ReadingLines(*lines)
    pose, imu, rotors = PoseSettings(*pose), ImuSettings(*imu), RotorSettings(*rotors)
    state_noise, tones = StateNoise(*state_noise), ToneSettings(*tones)
    position_std, vertical_std = pose.position_std, pose.vertical_std
    attitude_std, velocity_std, heading_std = pose.attitude_std, pose.velocity_std, pose.heading_std
    gyro_stds, accel_stds = imu.gyroscope_std, imu.accelerometer_std  # (N,) each
    pose_ticks = pose.tick
    now_position, now_velocity, now_rotation = now.position, now.velocity, now.rotation
    seen_position, seen_velocity, seen_rotation = seen.position, seen.velocity, seen.rotation
    gyro_walk, accel_walk = imu.gyroscope_walk, imu.accelerometer_walk
    gyro_bias0, accel_bias0 = imu.gyroscope_initial_bias, imu.accelerometer_initial_bias
    p_std, v_std = state_noise.position_std, state_noise.velocity_std
    a_std, w_std = state_noise.attitude_std, state_noise.rate_std
    keys, true_bias, ring, rotor_angle = lines.keys, lines.true_bias, lines.ring, lines.rotor_angle
    thrust, mass = truth.thrust, truth.mass
    depth = ring.shape[0]
    g = np.zeros(12)
    speeds = np.zeros(4)  # a vehicle's rotor speeds, where its tones are
    pose_noisy = position_std + vertical_std + attitude_std + velocity_std + heading_std > 0
    # the velocity's and heading's normals (the last two pairs) only where they have noise
    # (GNSS; a mocap fix has none): a pair is drawn by its index, so the first three pairs
    # are the same either way, and a zero std adds nothing to the reading
    pose_draws = 10 if velocity_std + heading_std > 0 else 6
    for j in range(start, stop):
        i = indices[j]
        gyro_std, accel_std = gyro_stds[i], accel_stds[i]
        step = step_count[i]
        slot = step % depth
        R = matrix_at(truth.rotation, i)
        if reset:  # a new episode's biases: zero, or drawn
            if gyro_bias0 + accel_bias0 > 0:
                _normals(keys[i, BIAS_KEY], 0, 6, g)
            else:
                g[:6] = 0.0
            for k in range(3):
                true_bias[i, k] = gyro_bias0 * g[k]
                true_bias[i, 3 + k] = accel_bias0 * g[3 + k]
        # the pose fix (taken every ``period`` steps; the slot keeps whatever it held else)
        if step % pose.period == 0 or reset:
            if pose_noisy:
                _normals(keys[i, POSE_KEY], step, pose_draws, g)
            late = pose_ticks[i] > 0 and not reset
            position = seen_position if late else now_position
            velocity = seen_velocity if late else now_velocity
            for k in range(3):
                std = vertical_std if k == 2 else position_std
                ring[slot, i, POSITION + k] = position[i, k] + std * g[k]
                ring[slot, i, VELOCITY + k] = velocity[i, k] + velocity_std * g[6 + k]
            attitude = (matrix_at(seen_rotation, i) if late
                        else matrix_at(now_rotation, i))
            turned = mat_mul_tuple(attitude, exp_tuple((attitude_std * g[3],
                                                        attitude_std * g[4],
                                                        attitude_std * g[5])))
            for k in range(9):
                ring[slot, i, ROTATION + k] = turned[k]
            ring[slot, i, HEADING] = wrap_angle(heading_of(attitude) + heading_std * g[9])
        # the IMU, its biases walking first
        if gyro_std + accel_std + gyro_walk + accel_walk > 0:
            _normals(keys[i, IMU_KEY], step, 12, g)
        else:
            g[:] = 0.0
        if not reset:
            for k in range(3):
                true_bias[i, k] += gyro_walk * g[6 + k]
                true_bias[i, 3 + k] += accel_walk * g[9 + k]
        specific = specific_force_vehicle(i, thrust, truth.force, truth.rotation, mass)
        if reset:
            specific = (specific[0], specific[1],
                        specific[2] + (truth.hover_thrust - thrust[i]) / mass[i])
        if tones.on:
            for r in range(4):
                speeds[r] = rotor_speed(truth.hover_rotor_thrusts[r] if reset
                                        else truth.rotor_thrusts[i, r],
                                        rotors.thrust_coefficient)
                if reset:  # a new episode's phases, uniform: one normal pair's angle each
                    first, second = gaussian_pair(keys[i, ROTOR_KEY], 8 * step + 4 + r)
                    rotor_angle[i, r] = math.atan2(second, first) % (2.0 * math.pi)
                else:
                    rotor_angle[i, r] = (rotor_angle[i, r] + speeds[r] * tones.dt) % (
                        2.0 * math.pi)
            shake = vibration_tones(i, rotor_angle[i], speeds, tones)
            specific = (specific[0] + shake[0], specific[1] + shake[1],
                        specific[2] + shake[2])
        for k in range(3):
            ring[slot, i, GYRO + k] = (truth.angular_velocity[i, k] + true_bias[i, k]
                                       + gyro_std * g[k])
            ring[slot, i, ACCEL + k] = specific[k] + true_bias[i, 3 + k] + accel_std * g[3 + k]
        if rotors.speed_std > 0:
            _normals(keys[i, ROTOR_KEY], step, 4, g)
        else:
            g[:4] = 0.0
        for k in range(4):
            rotor_thrust = (truth.hover_rotor_thrusts[k] if reset
                            else truth.rotor_thrusts[i, k])
            ring[slot, i, ROTORS + k] = (rotor_speed(rotor_thrust, rotors.thrust_coefficient)
                               + rotors.speed_std * g[k])
        if p_std + v_std + a_std + w_std > 0.0:  # SensorNoise: noise on the state itself
            _normals(keys[i, STATE_KEY], step, 12, g)
            for k in range(3):
                ring[slot, i, POSITION + k] = truth.position[i, k] + p_std * g[k]
                ring[slot, i, VELOCITY + k] = truth.velocity[i, k] + v_std * g[3 + k]
                ring[slot, i, GYRO + k] = truth.angular_velocity[i, k] + w_std * g[9 + k]
            turned = mat_mul_tuple(R, exp_tuple((a_std * g[6], a_std * g[7], a_std * g[8])))
            for k in range(9):
                ring[slot, i, ROTATION + k] = turned[k]
        if reset:
            for s in range(depth):
                if s != slot:
                    for k in range(READING_WIDTH):
                        ring[s, i, k] = ring[slot, i, k]


@njit(cache=True, nogil=True)
def measurement_kernel(start, stop, indices, step_count, ring, imu_delay, rotor_delay,
                       state_from_ring, position, velocity, rotation, rates, gyroscope,
                       accelerometer, rotor_speeds):
    """The measurement's raw readings from the delay line: the IMU's reading ``imu_delay``
    steps old, the rotors' ``rotor_delay``, for vehicles ``indices[start:stop]``; with
    ``state_from_ring`` (``SensorNoise``, no
    estimator) the state too, from the reading the IMU's delay gives."""
    depth = ring.shape[0]
    for j in range(start, stop):
        i = indices[j]
        step = step_count[i]
        imu = ring[max(step - imu_delay, 0) % depth, i]
        telemetry = ring[max(step - rotor_delay, 0) % depth, i]
        for k in range(3):
            gyroscope[i, k] = imu[GYRO + k]
            accelerometer[i, k] = imu[ACCEL + k]
        for k in range(4):
            rotor_speeds[i, k] = telemetry[ROTORS + k]
        if state_from_ring:
            for k in range(3):
                position[i, k] = imu[POSITION + k]
                velocity[i, k] = imu[VELOCITY + k]
                rates[i, k] = imu[GYRO + k]
                for c in range(3):
                    rotation[i, k, c] = imu[ROTATION + 3 * k + c]


@njit(cache=True)
def ideal_readings_kernel(thrust, force, rotation, mass, rotor_thrusts, thrust_coefficient,
                          accelerometer, rotor_speeds):
    """What ideal sensors read now: the specific force and the rotor speeds."""
    for i in range(thrust.shape[0]):
        specific = specific_force_vehicle(i, thrust, force, rotation, mass)
        for k in range(3):
            accelerometer[i, k] = specific[k]
        for k in range(4):
            rotor_speeds[i, k] = rotor_speed(rotor_thrusts[i, k], thrust_coefficient)
