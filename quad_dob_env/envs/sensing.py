"""The sensor stage: what the agent sees when ``Scenario.sensors`` adds noise and delay."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from quad_dob_env.envs.kernels import sensor_kernel
from quad_dob_env.memory import check_memory


class SensorStage:
    """Without sensor noise or delay the step kernel writes the observation itself
    (``clean`` is ``obs``); with them it writes the clean one into ``clean``, and
    ``measure`` makes what the agent sees in ``obs``: each reading noised from the
    vehicle's own counter-based key, then delayed by ``delay_steps`` through a ring."""

    def __init__(self, sensors, obs: NDArray[np.float32], rotation_mode: int) -> None:
        self.sensors, self.obs, self.rotation_mode = sensors, obs, rotation_mode
        self.clean = obs if sensors is None else np.zeros_like(obs)
        if sensors is None:
            return
        n = len(obs)
        self.stds = (float(sensors.position_std), float(sensors.velocity_std),
                     float(sensors.attitude_std), float(sensors.rate_std))
        self.keys = np.zeros(n, dtype=np.uint64)
        self.counters = np.zeros(n, dtype=np.int64)
        check_memory((sensors.delay_steps + 1) * obs.nbytes,
                     f"the sensor delay line of {sensors.delay_steps:,} steps for {n:,} "
                     "vehicles", "use a shorter SensorNoise.delay_steps")
        self.history = np.zeros((sensors.delay_steps + 1, *obs.shape), dtype=np.float32)
        self.slot = 0

    def start(self, index: int, rng: np.random.Generator) -> None:
        """A new episode of vehicle ``index``: its noise key, drawn from its generator."""
        if self.sensors is not None:
            self.keys[index] = rng.integers(0, 2**63, dtype=np.uint64)
            self.counters[index] = 0

    def measure(self, indices: NDArray[np.intp], rotation: NDArray, reset: bool) -> None:
        """Apply the sensor model to vehicles ``indices`` (all of them after a step)."""
        if self.sensors is None:
            return
        history = self.history
        if not reset:  # a step: the ring turns; a reset overwrites the newest reading
            self.slot = (self.slot + 1) % len(history)
        sensor_kernel(indices, self.clean, rotation, self.keys, self.counters, self.stds,
                      self.rotation_mode, history[self.slot])
        if reset:
            history[:, indices] = history[self.slot, indices]  # no older readings yet
        # the reading taken delay_steps ago, the oldest in the ring
        self.obs[indices] = history[(self.slot + 1) % len(history), indices]
