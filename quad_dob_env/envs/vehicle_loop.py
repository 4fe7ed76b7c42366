"""Benchmark v2's vehicle loop for a ``QuadrotorBatch``: the rotors' own model
(``quad_dob_env.dynamics.rotors``), its per-episode draws, and the inner loop's ticks.

``VehicleLoop`` gathers what the compiled step takes for them (``StepArguments.rotors``,
``rotor_state`` and ``inner``) and draws each episode's thrust scale and battery sag from a
stream spawned off the episode's child of the vehicle's generator (the sensors draw from that
child itself), so turning the factor on or off changes no other random draw.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.dynamics import Actuator
from quad_dob_env.dynamics.rotors import RotorModel
from quad_dob_env.envs.actions import MAX_RATE_COMMAND, RATE_GAIN
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
                 estimate: tuple[bool, NDArray, NDArray]) -> None:
        vehicle = scenario.vehicle
        self.model = RotorModel.of(vehicle, scenario.speed_motors, scenario.thrust_uncertainty,
                                   scenario.rotor_aerodynamics)
        self.uncertain = scenario.thrust_uncertainty
        self.thrust_scale = np.ones(n)
        self.sag_rate = np.zeros(n)
        self.ticks = scenario.inner_ticks
        self.active = scenario.inner_rate is not None
        # thrust_rates' rate loop is the inner loop, when there is one
        self.rates = self.active and action_mode == "thrust_rates"
        has_estimate, rotation, rate = estimate
        self.inner = (self.ticks, self.rates, RATE_GAIN, MAX_RATE_COMMAND,
                      np.array(actuator.moment_limit, dtype=float),
                      bool(has_estimate and self.active), rotation, rate)

    @property
    def speed_motors(self) -> bool:
        return self.model.speed_motors

    def hover_output(self, hover: NDArray) -> NDArray:
        """The actuator state at hover: rotor thrusts ``hover``, or their speeds."""
        if not self.speed_motors:
            return hover
        return np.sqrt(np.maximum(hover, 0.0) / self.model.thrust_coefficient)

    def rotor_state(self) -> tuple[NDArray, NDArray]:
        return (self.thrust_scale, self.sag_rate)

    def start(self, index: int, child: np.random.Generator | None) -> None:
        """Vehicle ``index``'s draws for a new episode, from a stream spawned off ``child``
        (the episode's child of its generator, whose own draws are the sensors'; None when
        nothing needs it): spawning draws nothing from it."""
        if self.uncertain:
            stream = child.spawn(1)[0]
            self.thrust_scale[index] = stream.uniform(*THRUST_SCALE_RANGE)
            self.sag_rate[index] = stream.uniform(*SAG_RATE_RANGE)

    @property
    def needs_streams(self) -> bool:
        return self.uncertain

    def sampled(self, index: int) -> dict[str, float]:
        """What was drawn for vehicle ``index`` (for ``info["sampled"]``)."""
        if not self.uncertain:
            return {}
        return {"thrust_scale": float(self.thrust_scale[index]),
                "battery_sag_rate": float(self.sag_rate[index])}
