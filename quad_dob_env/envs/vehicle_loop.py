"""Benchmark v2's vehicle loop for a ``QuadrotorBatch``: the rotors' own model
(``quad_dob_env.dynamics.rotors``), its per-episode draws, and the inner loop's ticks.

``VehicleLoop`` gathers what the compiled step takes for them (``StepArguments.rotors``,
``draws`` and ``inner``) and draws each episode's thrust scale and battery sag from a
stream spawned off the episode's child of the vehicle's generator (the sensors draw from that
child itself), so turning the factor on or off changes no other random draw.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.dynamics import Actuator
from quad_dob_env.dynamics.actuation import as_floats
from quad_dob_env.dynamics.rotors import RotorDraws, RotorModel
from quad_dob_env.envs.actions import MAX_RATE_COMMAND, RATE_GAIN
from quad_dob_env.envs.ticks import InnerLoop
from quad_dob_env.filters import butterworth_coefficients
from quad_dob_env.rng import named_stream
from quad_dob_env.scenarios import Scenario

# Per-episode true thrust coefficient over the nominal: air density from 0 °C to 30 °C at
# sea level, ρ ∝ 1/T (ISA: 1.225 kg/m³ at 15 °C), ±5 %.
THRUST_SCALE_RANGE = (0.95, 1.05)
# Battery sag [1/s]: the command's thrust goes as (1 - r t)². A LiPo pack from 4.05 to
# 3.5 V a cell (PX4's BAT_V_CHARGED, BAT_V_EMPTY) loses 25 % of its thrust per command over
# a 10-15 min flight, 0.03-0.04 %/s of thrust: r up to 2.5e-4 /s (0.05 %/s).
SAG_RATE_RANGE = (0.0, 2.5e-4)


class VehicleLoop:
    """The rotor model, the thrust draws and the inner loop of one core's scenario."""

    def __init__(self, scenario: Scenario, actuator: Actuator, n: int, action_mode: str,
                 estimate: tuple[bool, NDArray, NDArray],
                 pose: tuple[NDArray, NDArray, NDArray, NDArray] | None = None) -> None:
        vehicle = scenario.vehicle
        self.throttle = scenario.loop.throttle_map
        self.model = RotorModel.of(scenario.loop.airframe(vehicle), scenario.loop.speed_motors,
                                   scenario.loop.thrust_uncertainty,
                                   scenario.loop.rotor_aerodynamics, self.throttle)
        # each vehicle's lag and the rotors' κ, per-vehicle arrays set at a reset, so that an
        # episode may draw its own: the margin's time-constant scale is a number (in every
        # vehicle's from the start) or a range drawn at each reset (``start``)
        scale = scenario.loop.motor_time_constant_scale
        self.time_constant_scales = scale if isinstance(scale, tuple) else None
        self.unscaled_time_constants = scenario.loop.rotor_time_constants(vehicle, 1.0)
        self.time_constant, self.spin_down_time_constant = np.zeros(n), np.zeros(n)
        self.time_constant_scale = np.ones(n)
        self._scale_time_constants(slice(None), 1.0 if self.time_constant_scales else scale)
        self.thrust_model_factor = np.full(
            n, 0.0 if self.throttle is None else self.throttle.thrust_model_factor)
        self.uncertain = scenario.loop.thrust_uncertainty
        self.thrust_scale = np.ones(n)
        self.sag_rate = np.zeros(n)
        # the throttle map's draws: true hover throttle at the start, its drift [1/s], and
        # the estimate over the truth, 1 + ε
        self.hover_throttle = np.ones(n)
        self.hover_throttle_drift = np.zeros(n)
        self.hover_estimate_factor = np.ones(n)
        # the model mismatch's draws: each told value over the truth (the truth's scale is
        # its inverse; the thrust coefficient's is ``thrust_scale``)
        self.tolerance = scenario.loop.model_tolerance
        self.told_over_true = np.ones((n, 3))  # mass, inertia, thrust coefficient
        # each rotor's true k_F over the vehicle's (LoopOptions.rotor_thrust_mismatch)
        self.rotor_mismatch = scenario.loop.rotor_thrust_mismatch
        self.rotor_thrust_factor = np.ones((n, 4))
        self.ticks = scenario.inner_ticks
        self.active = scenario.loop.inner_rate is not None
        # thrust_rates' rate loop is the inner loop, when there is one
        self.rates = self.active and action_mode == "thrust_rates"
        has_estimate, rotation, rate = estimate
        # the autopilot's gyro low-pass on the rates every inner law reads (v3), stepped
        # once a tick at its end; its state starts settled on the scenario's initial rates
        cutoff = scenario.loop.gyro_cutoff
        self.gyro_filter = cutoff is not None and self.active
        self._gyro_coefficients = (butterworth_coefficients(cutoff, scenario.loop.inner_rate)
                                   if self.gyro_filter else (0.0,) * 5)
        self._initial_rate = np.array(scenario.initial_angular_velocity, dtype=float)
        self.gyro_state, self.gyro_output = np.zeros((n, 3, 2)), np.zeros((n, 3))
        if pose is None:  # the pose fix is taken at the step's end
            pose = (np.zeros(n, dtype=np.int64), np.zeros((1, 3)), np.zeros((1, 3)),
                    np.zeros((1, 3, 3)))
        pose_tick, pose_position, pose_velocity, pose_rotation = pose
        self.inner = InnerLoop(
            ticks=self.ticks, rate_law=self.rates, rate_gain=RATE_GAIN,
            max_rate=MAX_RATE_COMMAND,
            moment_limit=as_floats(actuator.moment_limit),
            has_estimate=bool(has_estimate and self.active), estimate_rotation=rotation,
            estimate_rate=rate, gyro_filter=self.gyro_filter,
            gyro_coefficients=self._gyro_coefficients, gyro_state=self.gyro_state,
            gyro_output=self.gyro_output, pose_tick=pose_tick, pose_position=pose_position,
            pose_velocity=pose_velocity, pose_rotation=pose_rotation,
            # the told inertia over the truth, which thrust_rates' rate loop flies
            told_inertia=self.told_over_true[:, 1],
            reads_command=scenario.loop.estimator_wrench == "commanded")
        self.draws = RotorDraws(
            time_constant=self.time_constant,
            spin_down_time_constant=self.spin_down_time_constant,
            thrust_model_factor=self.thrust_model_factor, thrust_scale=self.thrust_scale,
            sag_rate=self.sag_rate, hover_throttle=self.hover_throttle,
            hover_throttle_drift=self.hover_throttle_drift,
            hover_estimate_factor=self.hover_estimate_factor,
            rotor_thrust_factor=self.rotor_thrust_factor)

    @property
    def speed_motors(self) -> bool:
        return self.model.speed_motors

    def hover_output(self, hover: NDArray) -> NDArray:
        """The actuator state at hover: rotor thrusts ``hover``, or their speeds."""
        if not self.speed_motors:
            return hover
        return np.sqrt(np.maximum(hover, 0.0) / self.model.thrust_coefficient)

    def hover_throttle_estimate(self, time: NDArray) -> NDArray:
        """The autopilot's hover throttle t̂_h at each vehicle's ``time`` [s] (the throttle
        map's; 1 without it)."""
        if self.throttle is None:
            return np.ones_like(time, dtype=float)
        return (self.hover_throttle + self.hover_throttle_drift * time) * (
            self.hover_estimate_factor)

    def start(self, index: int, child: np.random.Generator | None) -> None:
        """Vehicle ``index``'s draws for a new episode, from a stream spawned off ``child``
        (the episode's child of its generator, whose own draws are the sensors'; None when
        nothing needs it): spawning draws nothing from it."""
        if self.gyro_filter:  # settled: output = input = the initial rates
            b0, _, b2, _, a2 = self._gyro_coefficients
            rate = self._initial_rate
            self.gyro_output[index] = rate
            self.gyro_state[index, :, 0] = (1.0 - b0) * rate
            self.gyro_state[index, :, 1] = (b2 - a2) * rate
        if self.uncertain:
            stream = child.spawn(1)[0]
            self.thrust_scale[index] = stream.uniform(*THRUST_SCALE_RANGE)
            self.sag_rate[index] = stream.uniform(*SAG_RATE_RANGE)
        if self.throttle is not None or self.tolerance is not None:
            # one stream, a fixed order: the throttle map's draws, then the model's (after
            # thrust uncertainty's own stream, when both fly)
            stream = child.spawn(1)[0]
            mapping = self.throttle
            if mapping is not None:
                self.hover_throttle[index] = stream.uniform(*mapping.hover_throttle)
                self.hover_throttle_drift[index] = stream.uniform(*mapping.hover_throttle_drift)
                error = mapping.hover_estimate_error
                self.hover_estimate_factor[index] = 1.0 + stream.uniform(-error, error)
            tolerance = self.tolerance
            if tolerance is not None:
                bounds = np.array([tolerance.mass, tolerance.inertia,
                                   tolerance.thrust_coefficient])
                self.told_over_true[index] = 1.0 + stream.uniform(-bounds, bounds)
                drawn = self.thrust_scale[index] if self.uncertain else 1.0
                self.thrust_scale[index] = drawn / self.told_over_true[index, 2]
        if self.time_constant_scales is not None:
            # a stream of its own name: switching another mechanism on moves no draw here
            self._scale_time_constants(index, named_stream(
                child, "motor_time_constant_scale").uniform(*self.time_constant_scales))
        if self.rotor_mismatch:
            # a stream of its own name, so switching the mismatch on changes no other draw;
            # rescaled to a mean of 1 (Molchanov et al. 2019)
            factors = 1.0 + named_stream(child, "rotor_thrust_mismatch").uniform(
                -self.rotor_mismatch, self.rotor_mismatch, 4)
            self.rotor_thrust_factor[index] = factors * (4.0 / factors.sum())

    def _scale_time_constants(self, index: int | slice, scale: float) -> None:
        """Vehicles ``index``'s lag: the unscaled time constants times ``scale``; the
        spin-down's 0 where it is the spin-up's (one time constant both ways)."""
        up, down = self.unscaled_time_constants
        self.time_constant_scale[index] = scale
        self.time_constant[index] = up * scale
        self.spin_down_time_constant[index] = 0.0 if down == up else down * scale

    def told_inertia(self, inertia: NDArray) -> NDArray:
        """The inertia (N, 3, 3) an autopilot's rate loop is told for the vehicles' true
        ``inertia``: the same array without a model tolerance."""
        if self.tolerance is None:
            return inertia
        return inertia * self.told_over_true[:, 1, None, None]

    def truth_scales(self, index: int) -> NDArray:
        """Vehicle ``index``'s true mass and inertia over the told (nominal) ones."""
        return 1.0 / self.told_over_true[index, :2]

    @property
    def needs_streams(self) -> bool:
        return (self.uncertain or self.throttle is not None or self.tolerance is not None
                or self.time_constant_scales is not None or bool(self.rotor_mismatch))

    def sampled(self, index: int) -> dict[str, float]:
        """What was drawn for vehicle ``index`` (for ``info["sampled"]``)."""
        drawn = {}
        if self.time_constant_scales is not None:
            drawn["motor_time_constant_scale"] = float(self.time_constant_scale[index])
        if self.rotor_mismatch:
            drawn.update({f"rotor_{k}_thrust_factor": float(self.rotor_thrust_factor[index, k])
                          for k in range(4)})
        if self.throttle is not None:
            drawn.update(hover_throttle=float(self.hover_throttle[index]),
                         hover_throttle_drift=float(self.hover_throttle_drift[index]),
                         hover_estimate_factor=float(self.hover_estimate_factor[index]))
        if self.tolerance is not None:
            told = self.told_over_true[index]
            drawn.update(mass_told_over_true=float(told[0]),
                         inertia_told_over_true=float(told[1]),
                         thrust_coefficient_told_over_true=float(told[2]))
        if not self.uncertain:
            return drawn
        return {**drawn, "thrust_scale": float(self.thrust_scale[index]),
                "battery_sag_rate": float(self.sag_rate[index])}
