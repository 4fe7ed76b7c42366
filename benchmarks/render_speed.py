"""How fast frames are drawn, and what recording a video of a 10 s episode costs.

Run by hand: ``python benchmarks/render_speed.py``. Flies geometric + NDOB (tuned) through
``paper-II`` (1,000 steps at 100 Hz) with ``render_mode="rgb_array"`` under
``gymnasium.wrappers.RecordVideo`` and prints the wall time of the whole episode, video
encoding included, and the time per frame. A few steps flown first compile the kernels (on
a first run), so the timing does not hold the compilation.
"""

from __future__ import annotations

import platform
import sys
import tempfile
import time

import gymnasium as gym
import numpy as np

import quad_dob_env  # noqa: F401
from quad_dob_composition import ReferencePolicy
from quad_dob_training.progress import Progress, compiling_notice

WARM_UP_STEPS = 5  # flown before the timed episode: a first run compiles the kernels there


def main() -> None:
    print("render_speed: geometric-ndob:tuned through paper-II, recorded to video, then 50 "
          "frames drawn and timed", file=sys.stderr, flush=True)
    with tempfile.TemporaryDirectory() as folder:
        env = gym.make("QuadDOB/Track-v1", scenario="paper-II", render_mode="rgb_array")
        policy = ReferencePolicy("geometric-ndob:tuned", env)
        with compiling_notice():
            obs, _ = env.reset(seed=0)
            for _ in range(WARM_UP_STEPS):
                obs, *_ = env.step(policy.predict(obs)[0])
        rate = env.metadata["render_fps"]  # frames a second of the episode
        seconds = -(-env.unwrapped.scenario.steps // rate)
        env = gym.wrappers.RecordVideo(env, folder, episode_trigger=lambda _: True,
                                       disable_logger=True)
        with Progress("render_speed", seconds + 2) as progress:
            env.reset(seed=0)
            frame_times = []
            start = time.perf_counter()
            obs, _ = env.reset(seed=0)
            done, steps = False, 0
            while not done:
                if steps % rate == 0:  # one unit a second of the episode
                    progress.start(f"episode second {steps // rate + 1}")
                action, _ = policy.predict(obs)
                obs, _, terminated, truncated, _ = env.step(action)
                steps += 1
                done = terminated or truncated
                if steps % rate == 0 or done:
                    progress.done(f"{steps} frames")
            progress.start("encoding the video")
            env.close()  # writes the video
            wall = time.perf_counter() - start
            progress.done()
            progress.start("50 frames drawn")
            drawn = env.unwrapped
            for _ in range(50):
                tick = time.perf_counter()
                drawn.render()
                frame_times.append(time.perf_counter() - tick)
            progress.done()
    print(f"machine: {platform.machine()}, Python {platform.python_version()}")
    print(f"RecordVideo of a {steps / 100:.0f} s episode ({steps} frames, paper-II, "
          f"geometric-ndob:tuned): {wall:.1f} s wall, encoding included")
    print(f"one rgb_array frame (480x360): {1e3 * np.median(frame_times):.1f} ms")


if __name__ == "__main__":
    main()
