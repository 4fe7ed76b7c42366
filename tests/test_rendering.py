import gymnasium as gym
import matplotlib
import numpy as np
import pytest

import quad_dob_env  # noqa: F401
from quad_dob_env.envs import QuadrotorEnv, QuadrotorVectorEnv

SHORT = {"duration": 0.5}


def test_rgb_array_frames_show_the_flight_and_change_as_it_moves():
    env = gym.make("QuadDOB/TrackResidual-v1", scenario="dryden-helix-gusts",
                   render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    assert first.shape == (360, 480, 3) and first.dtype == np.uint8
    colours = np.unique(first.reshape(-1, 3), axis=0)
    assert len(colours) > 20  # ground, paths, arms, rotors, thrust, text: not blank
    for _ in range(80):
        env.step(np.zeros(4, np.float32))
    later = env.render()
    assert np.mean(np.any(first != later, axis=2)) > 0.002  # the vehicle and its trail moved
    # the flown path (blue) appears once the vehicle has moved
    blue = np.all(later == (31, 119, 180), axis=2).sum()
    assert blue > np.all(first == (31, 119, 180), axis=2).sum()


def test_record_video_writes_a_file(tmp_path):
    env = gym.wrappers.RecordVideo(
        gym.make("QuadDOB/Hover-v1", scenario="gusty-hover", scenario_options=SHORT,
                 render_mode="rgb_array"), str(tmp_path / "videos"), episode_trigger=lambda _: True,
        disable_logger=True)
    env.reset(seed=0)
    done = False
    while not done:
        *_, terminated, truncated, _ = env.step(np.zeros(4, np.float32))
        done = terminated or truncated
    env.close()
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000


def test_vector_env_renders_its_first_vehicles_and_human_mode_runs_headless():
    vector = QuadrotorVectorEnv(6, "hover-calm", render_mode="rgb_array")
    vector.reset(seed=0)
    vector.step(np.zeros((6, 4)))
    frames = vector.render()
    assert len(frames) == 4 and all(f.shape == (360, 480, 3) for f in frames)
    with pytest.raises(ValueError, match="valid: None, rgb_array"):
        QuadrotorVectorEnv(2, render_mode="human")
    with pytest.raises(ValueError, match="valid: None, human, rgb_array"):
        QuadrotorEnv(render_mode="video")
    matplotlib.use("Agg")
    env = QuadrotorEnv("hover-calm", SHORT, render_mode="human")
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.zeros(4))
    env.close()


@pytest.mark.slow
def test_replay_writes_policies_side_by_side(tmp_path):
    from PIL import Image

    from quad_dob_training import cli

    out = tmp_path / "flight.gif"
    assert cli.main(["replay", "--policy", "geometric,pid", "--scenario", "hover-step-force",
                     "--out", str(out), "--fps", "5", "--width", "200"]) == 0
    gif = Image.open(out)
    assert gif.size == (400, 144) and gif.n_frames > 10
    with pytest.raises(SystemExit):
        cli.main(["replay", "--out", str(tmp_path / "flight.avi")])
