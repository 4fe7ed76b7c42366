"""``quad-dob replay``: one episode of one or more policies as a video, side by side.

Each policy flies the scenario from the same seed; frames (``quad_dob_env.envs.rendering``)
are labelled with the policy and put side by side, and written as a GIF (Pillow) or an MP4
(imageio with ffmpeg) at ``fps`` frames per second of flight time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageDraw

from quad_dob_composition import make_vector_env
from quad_dob_env.envs.rendering import FlightRenderer
from quad_dob_env.scenarios import make_scenario
from quad_dob_training.policies import check_spaces, make_policy

VIDEO_SUFFIXES = (".gif", ".mp4")


def fly_frames(spec: str, scenario_name: str, seed: int, every: int, size: tuple[int, int],
               *, trust_pickle: bool = False, benchmark: str = "v1") -> list[NDArray[np.uint8]]:
    """Frames of one episode of policy ``spec`` in ``benchmark``'s loop, one per ``every``
    control steps (``trust_pickle``: its model file may be unpickled,
    ``model_files.load_model``)."""
    scenario = make_scenario(scenario_name, benchmark=benchmark)
    # bare residual: the shipped policy of the benchmark the scenario flies
    policy = make_policy(spec, trust_pickle=trust_pickle, benchmark=scenario.loop.benchmark)
    env = make_vector_env(1, scenario, **policy.env_kwargs())
    check_spaces(policy, env)
    renderer = FlightRenderer(env.core, *size)
    obs, _ = env.reset(seed=[seed])
    frames = []
    for step in range(env.scenario.steps + 1):
        renderer.record(0)
        if step % every == 0:
            frames.append(_label(renderer.frame(0), policy.name))
        if step == env.scenario.steps:
            break
        actions = np.zeros((1, 4)) if policy.model is None else policy.act(obs)
        obs, _, terminated, truncated, _ = env.step(actions)
        if terminated[0] or truncated[0]:
            renderer.record(0)
            frames.append(_label(renderer.frame(0), policy.name))
            break
    return frames


def _label(frame: NDArray[np.uint8], text: str) -> NDArray[np.uint8]:
    image = Image.fromarray(frame)
    ImageDraw.Draw(image).text((8, frame.shape[0] - 18), text, fill=(20, 20, 20))
    return np.asarray(image)


def side_by_side(runs: list[list[NDArray[np.uint8]]]) -> list[NDArray[np.uint8]]:
    """One frame per time: the runs next to each other; a run that ended early holds its
    last frame."""
    length = max(len(frames) for frames in runs)
    return [np.concatenate([frames[min(k, len(frames) - 1)] for frames in runs], axis=1)
            for k in range(length)]


def write_video(frames: list[NDArray[np.uint8]], path: Path, fps: float) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix == ".gif":
        images = [Image.fromarray(frame) for frame in frames]
        images[0].save(path, save_all=True, append_images=images[1:], loop=0,
                       duration=round(1000 / fps), optimize=True)
    else:
        import imageio.v2 as imageio

        imageio.mimwrite(path, frames, fps=fps, macro_block_size=8)


def main(policies: list[str], scenario: str, seed: int, out: Path, fps: float,
         width: int, *, trust_pickle: bool = False, benchmark: str = "v1") -> int:
    """``quad-dob replay``; ``trust_pickle`` (``--trust-pickle``): model files may be
    unpickled; ``benchmark`` (``--benchmark``): the loop flown."""
    if out.suffix not in VIDEO_SUFFIXES:
        raise ValueError(f"--out must end in {' or '.join(VIDEO_SUFFIXES)}, got {str(out)!r}")
    if not policies:
        raise ValueError("--policy needs at least one policy")
    dt = make_scenario(scenario, benchmark=benchmark).dt
    every = max(1, round(1.0 / (fps * dt)))
    size = (width // 8 * 8, width * 3 // 4 // 8 * 8)  # codecs want multiples of 8
    runs = [fly_frames(spec, scenario, seed, every, size, trust_pickle=trust_pickle,
                       benchmark=benchmark) for spec in policies]
    frames = side_by_side(runs)
    write_video(frames, out, 1.0 / (every * dt))
    print(f"wrote {out} ({len(frames)} frames, {' | '.join(policies)} in {scenario}, "
          f"seed {seed})")
    return 0
