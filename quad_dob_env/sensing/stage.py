"""``SensingStage``: the batch's sensors, delay lines and estimator, between the physics
and every policy. The core (``quad_dob_env.envs.core``) runs it after each step and at
each reset; what it writes is ``measurement``, the one record controllers read."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from quad_dob_env.dynamics import VehicleState
from quad_dob_env.memory import check_memory
from quad_dob_env.params import VehicleParams
from quad_dob_env.rng import named_stream
from quad_dob_env.sensing.estimator import estimate_kernel, start_estimates_kernel
from quad_dob_env.sensing.measurement import Measurement
from quad_dob_env.sensing.models import POSE_KINDS, SensorSuite
from quad_dob_env.sensing.sensing_pass import (
    ESTIMATE_WIDTH,
    HISTORY_WIDTH,
    KEYS,
    READING_WIDTH,
    ImuSettings,
    PoseSettings,
    PoseState,
    ReadingLines,
    RotorSettings,
    StateNoise,
    ToneSettings,
    TrueState,
    ideal_readings_kernel,
    measurement_kernel,
    take_readings_kernel,
)
from quad_dob_env.sensing.stability import check_stability
from quad_dob_env.sensing.vibration import TABLE_STEP, VibrationTones, gain_table
from quad_dob_env.threads import run_over_batch
from quad_dob_env.variation import SensorNoise, range_bounds


class MeasureArguments(NamedTuple):
    """What ``measure_kernel`` takes after its vehicles, step counts and reset flag: built
    once a batch (its arrays are the batch's own), passed as plain tuples."""

    readings: tuple  # ``take_readings_kernel``'s from ``pose_now`` to ``lines``
    estimating: bool  # a suite's estimator runs
    # ``estimate_kernel``'s from ``ring`` to ``out_rates`` (zeros' gains without an
    # estimator: never read, but typed alike)
    estimate: tuple
    measurement: tuple  # ``measurement_kernel``'s from ``ring`` to ``rotor_speeds``


@njit(cache=True, nogil=True)
def measure_kernel(start, stop, indices, step_count, reset, readings, estimating, estimate,
                   measurement):
    """The stage's one compiled pass for vehicles ``indices[start:stop]``: their readings,
    the estimator's step (``predict`` but at a reset) and the measurement. Each vehicle's
    three only touch its own rows, so a slice runs them one after the other, with one
    hand-over to the threads instead of three."""
    take_readings_kernel(start, stop, indices, step_count, *readings, reset)
    if estimating:
        estimate_kernel(start, stop, indices, step_count, not reset, *estimate)
    measurement_kernel(start, stop, indices, step_count, *measurement)


def delay_steps(latency: float, dt: float) -> int:
    """A latency [s] resolved on the control grid: the first step at or after it."""
    return math.ceil(latency / dt - 1e-9)


class SensingStage:
    """What the controllers of a batch of ``n`` vehicles read (``measurement``).

    - ``sensing`` None and no ``extra_latency``: the identity, ``measurement`` holds the
      true state's own arrays (v1's loop, bit for bit); the IMU fields are ideal readings.
    - a ``SensorNoise``: the true state plus its Gaussian noise, ``delay_steps`` plus the
      extra latency late (no estimator); so is None with an extra latency, noise-free.
    - a ``SensorSuite``: its sensors, each late by its own latency plus the extra one (with
      ``ticks`` > 1, the pose's resolved on the grid of ``ticks`` intervals a step: its
      fix is taken where the step passes it, ``pose_tick``, the rest on the control grid), and
      the estimator (``quad_dob_env.sensing.estimator``) fusing them; ``vibration`` (gyro
      [rad/s], accelerometer [m/s²], RMS per axis) times ``vibration_scale`` adds to its
      IMU's white noise, ``tones`` (a ``VibrationTones``) times it adds the rotors'
      tones to its accelerometer, and ``unmodelled_pose_latency`` [s] delays its pose fix
      alone.

    ``unmodelled_pose_latency`` and ``vibration_scale`` are each a number or a (low, high)
    range drawn per episode (``start``), so the pose fix's delay and tick (``pose_delay``,
    ``pose_tick``) and the IMU's white noise (``gyroscope_std``, ``accelerometer_std``) are
    each vehicle's own, (N,) arrays the kernels read by vehicle.
    """

    def __init__(self, sensing: SensorSuite | SensorNoise | None, extra_latency: float,
                 truth: VehicleState, physics: tuple, vehicle: VehicleParams,
                 dt: float, hover: tuple[float, NDArray[np.float64]] | None = None,
                 vibration: tuple[float, float] = (0.0, 0.0), ticks: int = 1,
                 unmodelled_pose_latency: float | tuple[float, float] = 0.0,
                 vibration_scale: float | tuple[float, float] = 1.0,
                 tones: VibrationTones | None = None) -> None:
        n = truth.n
        self.sensing, self.dt, self.gravity = sensing, float(dt), float(vehicle.gravity)
        self.truth = truth
        # applied thrust (N,), non-gravity force but thrust (N, 3), mass (N,), rotor thrusts
        self.physics = physics
        # what the rotors give at a reset (they start at hover; nothing is applied yet)
        weight = vehicle.hover_thrust
        self._hover = (float(weight), np.full(4, weight / 4)) if hover is None else (
            float(hover[0]), np.asarray(hover[1], dtype=float))
        self.thrust_coefficient = float(vehicle.thrust_coefficient)
        extra = delay_steps(extra_latency, dt)
        self.identity = sensing is None and extra == 0
        self.keys = np.zeros((n, KEYS), dtype=np.uint64)
        self.true_bias = np.zeros((n, 6))
        self.estimating = isinstance(sensing, SensorSuite)
        # each vehicle's pose fix: its delay in steps, the tick after which a step's fix is
        # taken (0: its end), and the state there (the kernels write it: ``QuadrotorBatch``'s
        # inner loop); filled in place, the kernels' records hold these arrays
        self.pose_delay = np.zeros(n, dtype=np.int64)
        self.pose_tick = np.zeros(n, dtype=np.int64)
        self.pose_state = (truth.position, truth.velocity, truth.rotation)
        # each vehicle's IMU white noise per reading, its vibration included
        self.gyroscope_std, self.accelerometer_std = np.zeros(n), np.zeros(n)
        # the ranges drawn per episode (None: a fixed value), and each vehicle's unmodelled
        # pose latency [s] and vibration scale: its draw, else the fixed value
        self._ranges = tuple(value if isinstance(value, tuple) else None
                             for value in (unmodelled_pose_latency, vibration_scale))
        (latency_low, latency_high), (scale_low, _) = (range_bounds(unmodelled_pose_latency),
                                                       range_bounds(vibration_scale))
        self.drawn = np.tile((latency_low, scale_low), (n, 1))
        self._fresh = False
        self._state_noise = StateNoise()
        self._imu = ImuSettings(self.gyroscope_std, self.accelerometer_std)
        # the rotors' vibration tones (v4): each vehicle's rotor amplitudes, its scale's
        # draw times the level's share of one rotor (four of independent phase: level/√2)
        self.rotor_angle = np.zeros((n, 4))
        self.tone_amplitudes = np.zeros((2, n))
        self._tones = tones
        self._tone_settings = ToneSettings(self.tone_amplitudes[0], self.tone_amplitudes[1],
                                           np.zeros((2, 2)))
        self._rotors = RotorSettings(speed_std=0.0,
                                     thrust_coefficient=self.thrust_coefficient)
        if self.estimating:
            pose, imu = sensing.pose, sensing.imu
            # a fix every so many steps: the nearest grid period not faster than the rate
            self.period = max(1, math.ceil(1.0 / (pose.rate * dt) - 1e-9))
            self._pose = PoseSettings(
                tick=self.pose_tick, kind=POSE_KINDS.index(pose.kind),
                period=self.period,
                position_std=pose.position_std, vertical_std=pose.vertical_std,
                attitude_std=pose.attitude_std, velocity_std=pose.velocity_std,
                heading_std=pose.heading_std)
            root = math.sqrt(dt)
            self._imu_noise = (imu.gyroscope_noise_density / root,
                               imu.accelerometer_noise_density / root)
            self._vibration = vibration
            if tones is not None:
                # the table reaches past the blade-pass frequency of a rotor at twice its
                # largest thrust (above it the last row holds)
                fastest = math.sqrt(2 * vehicle.max_rotor_thrust / vehicle.thrust_coefficient)
                self._tone_settings = ToneSettings(
                    self.tone_amplitudes[0], self.tone_amplitudes[1],
                    gain_table(tones, tones.blades * fastest / (2 * math.pi)),
                    table_step=TABLE_STEP, blades=int(tones.blades), dt=float(dt), on=True)
            self._shake(slice(None), scale_low)
            self._imu = ImuSettings(
                gyroscope_std=self.gyroscope_std, accelerometer_std=self.accelerometer_std,
                gyroscope_walk=imu.gyroscope_bias_walk * root,
                accelerometer_walk=imu.accelerometer_bias_walk * root,
                gyroscope_initial_bias=imu.gyroscope_initial_bias,
                accelerometer_initial_bias=imu.accelerometer_initial_bias)
            self._rotors = self._rotors._replace(speed_std=sensing.rotors.speed_std)
            self._pose_latency, self._extra_latency, self._extra, self._ticks = (
                pose.latency, extra_latency, extra, ticks)
            told = self.pose_delay_of(0.0)[0]
            # on ticks the IMU, on the control grid, is read no later than the pose (which
            # the estimator needs): v3's own latencies are whole steps for it
            imu_delay = delay_steps(imu.latency, dt) + extra
            if ticks > 1:
                imu_delay = min(imu_delay, told)
            # every vehicle's until it draws its own (the range's low end), and the deepest
            # the delay lines must hold (the range's top: a delay grows with the latency)
            self.pose_delay[:], self.pose_tick[:] = self.pose_delay_of(latency_low)
            pose_depth = self.pose_delay_of(latency_high)[0]
            self.imu_delay = imu_delay
            # the estimator compensates the lag it is told, not one the suite does not say
            self.lag = max(told - imu_delay, 0)
            self.rotor_delay = delay_steps(sensing.rotors.latency, dt) + extra
            if imu_delay > self.pose_delay[0]:
                raise ValueError(
                    f"sensing {sensing.name!r}: the IMU's latency {imu.latency:g} s is above "
                    f"the pose fix's {pose.latency:g} s; the estimator runs on the IMU and "
                    f"meets each fix at its own, earlier time: allowed, IMU latency <= pose "
                    f"latency")
            gains = sensing.estimator
            self._gains = (gains.position_bandwidth, gains.attitude_bandwidth,
                           gains.velocity_bandwidth)
            check_stability(sensing.name, self._gains, dt, self.period, self.lag)
        else:  # Scenario refuses an unmodelled pose latency (and vibration) without a suite
            self._gains = (0.0, 0.0, 0.0)  # no estimator: typed alike, never read
            self.period = 1
            self.lag = 0
            self._pose = PoseSettings(tick=self.pose_tick)
            state_delay = extra + (0 if sensing is None else int(sensing.delay_steps))
            if isinstance(sensing, SensorNoise):
                self._state_noise = StateNoise(
                    position_std=float(sensing.position_std),
                    velocity_std=float(sensing.velocity_std),
                    attitude_std=float(sensing.attitude_std), rate_std=float(sensing.rate_std))
            self.pose_delay[:] = pose_depth = self.imu_delay = state_delay
            self.rotor_delay = state_delay
        if self.estimating and ticks > 1:  # a vehicle may take its fix within a step
            self.pose_state = (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3, 3)))
        # the estimator integrates over the IMU's last two readings: one slot more
        depth = max(pose_depth, self.imu_delay, self.rotor_delay) + 1 + int(self.estimating)
        history = (self.lag + self.period + 1) if self.estimating else 1
        # what the filter reads each step: the pose's (each vehicle's) and IMU's delays and
        # its told lag
        self._filter_delays = (self.pose_delay, self.imu_delay, self.lag)
        check_memory(n * 8 * (depth * READING_WIDTH + history * HISTORY_WIDTH),
                     f"the sensing delay lines of {depth - 1:,} steps for {n:,} vehicles",
                     "use a shorter latency (SensorNoise.delay_steps, extra_latency, "
                     "unmodelled_pose_latency)")
        self.ring = np.zeros((depth, n, READING_WIDTH))
        self.estimate_state = np.zeros((n, ESTIMATE_WIDTH))
        self.history = np.zeros((history, n, HISTORY_WIDTH))
        if self.identity:
            self.measurement = Measurement(truth.position, truth.velocity, truth.rotation,
                                           truth.angular_velocity)
            self.measurement.gyroscope = truth.angular_velocity
        else:
            self.measurement = Measurement(*(np.zeros_like(getattr(truth, name)) for name in (
                "position", "velocity", "rotation", "angular_velocity")))
            self.measurement.rotation[:] = np.eye(3)
        # the readings kernel's records, built once: their arrays are the batch's own for its
        # life; passed as plain tuples (numba types a named tuple on a slower path each call)
        thrust, force, mass, rotor_thrusts = physics
        self._truth = tuple(TrueState(
            position=truth.position, velocity=truth.velocity, rotation=truth.rotation,
            angular_velocity=truth.angular_velocity, thrust=thrust, force=force, mass=mass,
            rotor_thrusts=rotor_thrusts, hover_thrust=self._hover[0],
            hover_rotor_thrusts=self._hover[1]))
        # the pose fix reads the state now at a reset and where its tick is 0, else where the
        # step passed its latency
        self._pose_now = tuple(PoseState(position=truth.position, velocity=truth.velocity,
                                         rotation=truth.rotation))
        position, velocity, rotation = self.pose_state
        self._pose_seen = tuple(PoseState(position=position, velocity=velocity,
                                          rotation=rotation))
        self._settings = (tuple(self._pose), tuple(self._imu), tuple(self._rotors),
                          tuple(self._state_noise), tuple(self._tone_settings))
        self._lines = tuple(ReadingLines(keys=self.keys, true_bias=self.true_bias,
                                         ring=self.ring, rotor_angle=self.rotor_angle))
        m = self.measurement
        self.measure_arguments = MeasureArguments(
            readings=(self._pose_now, self._pose_seen, self._truth, *self._settings,
                      self._lines),
            estimating=self.estimating,
            estimate=(self.ring, self._filter_delays, self.period, self._pose.kind,
                      self._gains, self.dt, self.gravity, self.estimate_state, self.history,
                      m.position, m.velocity, m.rotation, m.angular_velocity),
            measurement=(self.ring, self.imu_delay, self.rotor_delay, not self.estimating,
                         m.position, m.velocity, m.rotation, m.angular_velocity, m.gyroscope,
                         m.accelerometer, m.rotor_speeds))

    def pose_delay_of(self, unmodelled: float) -> tuple[int, int]:
        """A suite's pose fix's delay in steps with ``unmodelled`` [s] of latency on top,
        and the tick after which it is taken (0: the step's end). With ``ticks`` > 1 the
        latency is resolved on the physics grid: a fix read ``q`` steps late was taken
        ``r`` ticks before its step's end."""
        latency, ticks = self._pose_latency, self._ticks
        if ticks == 1:
            return delay_steps(latency + unmodelled, self.dt) + self._extra, 0
        late = delay_steps(latency + self._extra_latency + unmodelled, self.dt / ticks)
        return late // ticks, (ticks - late % ticks if late % ticks else 0)

    def _shake(self, index: int | slice, scale: float) -> None:
        """Vehicle ``index``'s vibration times ``scale``: (v3) white noise of its own RMS on
        every reading, the rotors' effect left by the autopilot's filters, added to the
        sensor's own in quadrature; (v4) its tones' amplitudes."""
        (gyroscope, accelerometer), (gyro_vibration, accelerometer_vibration) = (
            self._imu_noise, self._vibration)
        self.gyroscope_std[index] = math.hypot(gyroscope, scale * gyro_vibration)
        self.accelerometer_std[index] = math.hypot(accelerometer,
                                                   scale * accelerometer_vibration)
        if self._tones is not None:
            self.tone_amplitudes[0, index] = scale * self._tones.rotor_level / math.sqrt(2)
            self.tone_amplitudes[1, index] = scale * self._tones.blade_pass_level / math.sqrt(2)

    def start(self, index: int, stream: np.random.Generator | None) -> None:
        """A new episode's sensor keys for vehicle ``index``, from ``stream``, the episode's
        child of its generator (None: the identity needs none), and where a range is given
        its unmodelled pose latency and vibration scale, from the child's stream named for
        them (``rng.named_stream``): making it draws nothing from the child, so the wind,
        gusts, starts and randomisation it gives are the same with any sensing, and no
        other mechanism switched on moves these draws."""
        if self.identity:
            return
        self.keys[index] = stream.integers(1, 2**63, size=KEYS, dtype=np.uint64)
        if self._ranges == (None, None):
            return
        # one uniform per value, drawn whether it is a range or not: switching one range
        # on changes not the other's draw
        uniforms = named_stream(stream, "sensing_ranges").random(2)
        for k, bounds in enumerate(self._ranges):
            if bounds is not None:
                low, high = bounds
                self.drawn[index, k] = low + (high - low) * uniforms[k]
        latency, scale = self._ranges
        if latency is not None:
            self.pose_delay[index], self.pose_tick[index] = self.pose_delay_of(
                self.drawn[index, 0])
        if scale is not None:
            self._shake(index, self.drawn[index, 1])

    def sampled(self, index: int) -> dict[str, float]:
        """What was drawn for vehicle ``index``'s episode (for ``info["sampled"]``)."""
        return {name: float(self.drawn[index, k]) for k, name in enumerate(
            ("unmodelled_pose_latency", "imu_vibration_scale")) if self._ranges[k] is not None}

    def measure(self, indices: NDArray[np.intp], step_count: NDArray[np.int64],
                reset: bool) -> None:
        """The readings of the true state now, and the measurement they give (nothing
        for the identity: see ``refresh_ideal``)."""
        self._fresh = False  # the identity's IMU readings are for the state before
        if self.identity:
            return
        if reset:
            self.start_estimates(indices)
        run_over_batch(measure_kernel, len(indices), indices, step_count, reset,
                       *self.measure_arguments)

    def start_estimates(self, indices: NDArray[np.intp]) -> None:
        """At a reset of vehicles ``indices``, before their readings: the estimator starts on
        the true state (nothing without one). ``measure_kernel`` with ``reset`` follows."""
        if self.estimating:
            truth = self.truth
            start_estimates_kernel(indices, truth.position, truth.velocity, truth.rotation,
                                   self.estimate_state, self.history)

    def refresh_ideal(self) -> None:
        """The identity's IMU and rotor readings for the state now (``measurement`` holds
        the true state's own arrays; these two are computed when first asked for after a
        step or reset)."""
        if self._fresh:
            return
        self._fresh = True
        thrust, force, mass, rotor_thrusts = self.physics
        m = self.measurement
        ideal_readings_kernel(thrust, force, self.truth.rotation, mass, rotor_thrusts,
                              self.thrust_coefficient, m.accelerometer, m.rotor_speeds)
