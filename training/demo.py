"""``quad-dob demo``: fly each scenario once and say what happened.

With no controller yet, the vehicle holds hover thrust and zero moment (action 0), so the
demo shows the simulator, not control: how long each scenario lasts open-loop and why it
ends.
"""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np

import quad_dob_env  # noqa: F401  (registers the env ids)

DEMO_SCENARIOS = ("hover-calm", "hover-step-force", "paper-none", "paper-I", "paper-II",
                  "paper-IIA", "ground-effect-landing")


def fly_open_loop(scenario: str, seed: int = 0) -> dict:
    """One episode at hover thrust; returns what happened."""
    env = gym.make("QuadDOB/Track-v0", scenario=scenario)
    env.reset(seed=seed)
    hover = np.zeros(4, dtype=np.float32)
    errors, tilts = [], []
    terminated = truncated = False
    info: dict = {}
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(hover)
        errors.append(np.linalg.norm(info["position_error"]))
        tilts.append(env.unwrapped.core.state.rotation[0, 2, 2])
    env.close()
    return {
        "scenario": scenario,
        "flown_s": info["time"],
        "ended_by": info.get("termination_reason", ""),
        "rms_position_error_m": float(np.sqrt(np.mean(np.square(errors)))),
        "final_position_error_m": float(errors[-1]),
        "max_tilt_deg": float(np.degrees(np.arccos(np.clip(min(tilts), -1, 1)))),
        "steps": len(errors),
    }


def main(seed: int = 0) -> int:
    start = time.perf_counter()
    print("Open-loop hover thrust (action 0) in every scenario; controllers arrive with "
          "baselines/.\n")
    header = (f"| {'scenario':<22} | flown [s] | ended by         | RMS pos. err [m] "
              "| final pos. err [m] | max tilt [deg] |")
    print(header)
    print("|" + "|".join("-" * len(cell) for cell in header.split("|")[1:-1]) + "|")
    steps = 0
    for name in DEMO_SCENARIOS:
        r = fly_open_loop(name, seed)
        steps += r["steps"]
        print(f"| {name:<22} | {r['flown_s']:9.2f} | {r['ended_by']:<16} | "
              f"{r['rms_position_error_m']:16.3f} | {r['final_position_error_m']:18.3f} | "
              f"{r['max_tilt_deg']:14.1f} |")
    elapsed = time.perf_counter() - start
    print(f"\n{steps} steps in {elapsed:.2f} s (compilation included on a first run).")
    return 0
