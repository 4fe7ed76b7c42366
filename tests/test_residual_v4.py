"""Issue 56's pieces for the residual that sees its loop: the loop view (history, thrust-path
residual, period), the supervisor, and training at both rates with the margin's corner."""

import math

import gymnasium as gym
import numpy as np
import pytest

from quad_dob_composition import make_vector_env
from quad_dob_env.benchmark_v3 import TUNING_MARGIN
from quad_dob_env.benchmark_v4 import V4_LOOPS
from quad_dob_env.residual import ResidualOptions
from quad_dob_env.residual.loop_view import LoopView
from quad_dob_env.residual.supervisor import Supervisor, SupervisorLimits, attitude_angle
from quad_dob_env.so3 import exp as exp_map
from quad_dob_training.rl.loop_randomization import LoopRandomization
from quad_dob_training.rl.vec_env import (
    QuadrotorSB3VecEnv,
    draw_loops,
    env_options,
    loop_scenario_options,
)

SEEING = {"history_steps": 3, "thrust_path_input": True, "period_input": True}
LIMITS = {"body_rate": 7.0, "attitude_error": 1.5, "residual_share": 0.45}


def test_the_history_holds_the_last_k_steps_newest_first_and_starts_empty():
    view = LoopView(2, 0.01, ResidualOptions(history_steps=3), 1.0, 9.81)
    for step in range(1, 5):  # residual k and velocity error -k at step k
        view.advance(np.full((2, 3), -step), np.full((2, 4), step), np.zeros(2), np.zeros(2))
    extra = np.zeros((2, 16 + view.size), np.float32)
    view.write(extra, 16, np.zeros((2, 3)))
    assert extra[0, 16:28].tolist() == [4] * 4 + [3] * 4 + [2] * 4
    assert extra[0, 28:37].tolist() == [-4] * 3 + [-3] * 3 + [-2] * 3
    view.restart(np.array([1]))
    view.write(extra, 16, np.zeros((2, 3)))
    assert not extra[1, 16:].any() and extra[0, 16] == 4


def test_the_thrust_path_residual_is_neural_flys_signal_through_a_5_hz_low_pass():
    # an oracle from the equations: f_z / m g0 = (a_z - T_c / m) / g0, y += (1 - e^{-w dt}) (x - y)
    mass, gravity, dt = 2.0, 9.81, 0.02
    view = LoopView(1, dt, ResidualOptions(thrust_path_input=True, period_input=True), mass,
                    gravity)
    blend = 1.0 - math.exp(-2.0 * math.pi * 5.0 * dt)
    expected = 0.0
    for accelerometer, thrust in ((9.0, 20.0), (10.5, 19.0), (9.81, 19.62)):
        view.advance(np.zeros((1, 3)), np.zeros((1, 4)), np.array([accelerometer]),
                     np.array([thrust]))
        expected += blend * ((accelerometer - thrust / mass) / gravity - expected)
    extra = np.zeros((1, 18), np.float32)
    view.write(extra, 16, np.zeros((1, 3)))
    assert extra[0, 16] == pytest.approx(expected, rel=1e-6)
    assert extra[0, 17] == pytest.approx(2.0)  # 50 Hz reads 2 periods of 10 ms


def test_the_observation_names_every_column_of_the_loop_view():
    options = ResidualOptions(residual_mode="acceleration", **SEEING)
    names = [entry.name for entry in options.observation_entries]
    assert names[-4:] == ["residual_history", "velocity_error_history",
                          "thrust_path_residual", "control_period"]
    env = make_vector_env(2, "random-tracks", benchmark="v4",
                          base_controller="geometric-ndob:tuned", residual_options=options)
    obs, _ = env.reset(seed=[0, 1])
    assert obs.shape[1] == env.core.observation_size + sum(
        entry.size for entry in options.observation_entries)
    for _ in range(5):
        before = obs
        obs, *_ = env.step(np.full((2, 4), 0.25))
    history = obs[:, -2 - 21:-2 - 9]
    assert np.allclose(history, 0.25)  # the residual flown, 3 steps of 4
    # the newest velocity error in the history is the one the step before showed
    own = env.core.observation_size
    shown = before[:, own + 13:own + 16]
    assert np.array_equal(obs[:, -2 - 9:-2 - 6], shown) and np.any(shown != 0)
    assert np.all(obs[:, -1] == 1.0)  # random-tracks flies 100 Hz


def test_the_reference_jerk_is_the_planners_at_the_step_about_to_be_flown():
    """Oracle: the figure-8's jerk in closed form, x⃛_d = d³/dt³ of its own position, by a
    central difference of the reference's positions (independent of its derivative code)."""
    options = ResidualOptions(residual_mode="acceleration", reference_jerk_input=True)
    assert options.observation_entries[-1].name == "desired_jerk"
    env = make_vector_env(1, "figure8-wind-0", benchmark="v4",
                          base_controller="geometric-ndob:tuned", residual_options=options)
    obs, _ = env.reset(seed=[3])
    core, dt = env.core, env.scenario.dt
    positions = core.reference_table[:, 0]  # the reference's positions, one row per step
    for _ in range(200):
        obs, *_ = env.step(np.zeros((1, 4)))
    row = int(core.reference_row[0])
    # third derivative by the five-point central difference, O(dt²)
    difference = (positions[row + 2] - 2 * positions[row + 1] + 2 * positions[row - 1]
                  - positions[row - 2]) / (2 * dt ** 3)
    assert np.allclose(obs[0, -3:], difference, rtol=0.02, atol=0.01)
    assert np.abs(obs[0, -3:]).max() > 0.1  # a figure-8 has jerk to show


def test_the_actors_input_holds_no_truth():
    """Wind, disturbance, true state and the loop's parameters changed under a fixed
    measurement: the observation the actor reads is the same, column for column."""
    options = ResidualOptions(residual_mode="acceleration", supervisor=LIMITS,
                              reference_jerk_input=True, **SEEING)
    env = make_vector_env(3, "dryden-helix-gusts", benchmark="v4",
                          base_controller="geometric-ndob:tuned", residual_options=options)
    env.reset(seed=[5, 6, 7])
    for _ in range(20):
        env.step(np.full((3, 4), 0.1))
    before = env.observations().copy()
    core = env.core
    core.state.position += 0.3  # the truth moves; the estimate does not
    core.state.velocity -= 0.5
    core.state.angular_velocity += 1.0
    core.applied.thrust[:] *= 1.3  # the rotors gave something else
    env.residual.plan()  # the observation again, from what the stack has
    after = env.observations()
    assert np.array_equal(before, after)


def test_the_supervisor_trips_fades_holds_and_recovers_with_hysteresis():
    limits = SupervisorLimits(body_rate=1.0, attitude_error=1.0, residual_share=1.0,
                              release=0.5, hold=0.05, fade_time=0.02, recover_time=0.04)
    supervisor = Supervisor(1, 0.01, limits)
    calm, rough, between = np.array([0.1]), np.array([1.2]), np.array([0.8])
    factors = []
    for rate in [calm, rough, between, between, between, calm, calm, calm, calm, calm, calm,
                 calm, calm, calm]:
        factors.append(float(supervisor.advance(rate, np.zeros(1), np.zeros(1))[0]))
    # tripped at step 1, to 0 over two steps; "between" (under the limit, over its release)
    # holds it; five calm steps (hold 0.05 s) release it, then it rises over four
    assert factors[:5] == pytest.approx([1.0, 0.5, 0.0, 0.0, 0.0])
    assert factors[5:9] == pytest.approx([0.0] * 4)
    assert factors[9:] == pytest.approx([0.25, 0.5, 0.75, 1.0, 1.0])
    assert not supervisor.tripped[0]  # released
    supervisor.restart(np.array([0]))
    assert supervisor.factor[0] == 1.0 and supervisor.calm_time[0] == 0.0


def test_the_attitude_error_is_the_tilt_between_the_thrust_axes_not_the_heading():
    desired = np.stack([exp_map(np.array([0.1, -0.2, 0.3]))])
    assert attitude_angle(desired @ exp_map(np.array([0.0, 0.0, 0.4])), desired) == (
        pytest.approx([0.0], abs=1e-7))  # a turn about b3 leaves b3 where it was
    assert attitude_angle(desired @ exp_map(np.array([0.25, 0.0, 0.0])), desired) == (
        pytest.approx([0.25]))


def test_bad_loop_view_and_supervisor_options_are_named():
    with pytest.raises(ValueError, match="history_steps must be a whole number"):
        ResidualOptions(history_steps=2.5)
    with pytest.raises(ValueError, match="history_steps must be a whole number"):
        ResidualOptions(history_steps=-1)
    with pytest.raises(ValueError, match="thrust_path_input must be true or false"):
        ResidualOptions(thrust_path_input="yes")
    with pytest.raises(ValueError, match="supervisor key"):
        ResidualOptions(supervisor={**LIMITS, "rate": 1.0})
    with pytest.raises(ValueError, match="supervisor release"):
        ResidualOptions(supervisor={**LIMITS, "release": 1.5})
    options = ResidualOptions(supervisor=LIMITS, history_steps=4)
    assert options.keys() == {"supervisor": {**LIMITS, "release": 0.5, "hold": 0.5,
                                             "fade_time": 0.1, "recover_time": 1.0},
                              "history_steps": 4}
    assert ResidualOptions.from_keys(options.keys()) == options


V4_SPEC = {"groups": 4, "vehicle": ["paper", "paper", "neural-fly", "neural-fly"],
           "control_rate": [100, 50], "margin_groups": 1,
           "motor_time_constant_scale": [0.8, 1.8], "unmodelled_pose_latency": [0.0, 0.03],
           "thrust_model_factor": [0.526, 0.659]}


def test_the_rates_cycle_and_one_slow_group_flies_the_margins_corner():
    for seed in range(20):
        loops = draw_loops(V4_SPEC, seed, 0.01)
        assert [loop["dt"] for loop in loops] == [0.01, 0.02, 0.01, 0.02]
        assert [loop["vehicle"] for loop in loops] == V4_SPEC["vehicle"]
        corner = [loop for loop in loops if loop["dt"] == 0.02
                  and loop["motor_time_constant_scale"]
                  >= TUNING_MARGIN["motor_time_constant_scale"]
                  and loop["unmodelled_pose_latency"] >= TUNING_MARGIN["unmodelled_pose_latency"]]
        assert corner, seed
    # without the new keys, a spec draws what it drew before them
    older = {key: value for key, value in V4_SPEC.items()
             if key not in ("control_rate", "margin_groups")}
    drawn = draw_loops(older, 3, 0.01)
    assert all("dt" not in loop for loop in drawn)
    assert [{k: v for k, v in loop.items() if k != "dt"} for loop in draw_loops(
        {**older, "control_rate": [100]}, 3, 0.01)] == drawn
    with pytest.raises(ValueError, match="margin_groups must be a whole number from 0 to 2"):
        draw_loops({**V4_SPEC, "margin_groups": 3}, 0, 0.01)
    with pytest.raises(ValueError, match="control_rate lists rates"):
        draw_loops({**V4_SPEC, "control_rate": [100, -50]}, 0, 0.01)


def test_one_policy_trains_at_both_rates_in_v4s_throttle_map():
    options = loop_scenario_options({"thrust_model_factor": 0.55}, "paper", "v4")
    assert options["throttle_map"] == V4_LOOPS["paper"].throttle_map.__class__(
        **{**V4_LOOPS["paper"].throttle_map.__dict__, "thrust_model_factor": 0.55})
    env = QuadrotorSB3VecEnv(8, "random-tracks", seed=0, benchmark="v4",
                             base_controller="geometric-ndob:tuned",
                             residual_mode="acceleration", loop_randomization=V4_SPEC,
                             **SEEING)
    assert [venv.scenario.dt for venv in env.vector_envs] == [0.01, 0.02, 0.01, 0.02]
    obs = env.reset()
    assert obs.shape[0] == 8
    env.step_async(np.zeros((8, 4)))
    obs, rewards, _, _ = env.step_wait()
    assert np.all(np.isfinite(rewards))
    assert obs[:, -1].tolist() == [1.0, 1.0, 2.0, 2.0] * 2


def test_supervisor_in_training_false_trains_unsupervised_and_flies_supervised():
    """The groups of a spec with ``supervisor_in_training: false`` fly no supervisor, in
    quad-dob train's vector env and in rl-zoo3's single envs; the run's env options (what
    evaluation flies) keep it; a spec without the key draws as before."""
    kwargs = dict(benchmark="v4", base_controller="geometric-ndob:tuned",
                  residual_mode="acceleration", supervisor=LIMITS, **SEEING)
    spec = {**V4_SPEC, "supervisor_in_training": False}
    assert [{k: v for k, v in loop.items() if k != "supervisor_in_training"}
            for loop in draw_loops(spec, 4, 0.01)] == draw_loops(V4_SPEC, 4, 0.01)
    trained = QuadrotorSB3VecEnv(8, "random-tracks", seed=0, loop_randomization=spec, **kwargs)
    assert all(venv.residual.supervisor is None for venv in trained.vector_envs)
    supervised = QuadrotorSB3VecEnv(8, "random-tracks", seed=0, loop_randomization=V4_SPEC,
                                    **kwargs)
    assert all(venv.residual.supervisor is not None for venv in supervised.vector_envs)
    assert env_options({**kwargs, "loop_randomization": spec})["supervisor"] == LIMITS
    single = LoopRandomization(gym.make("QuadDOB/TracksResidual-v4", scenario="random-tracks",
                                        **{k: v for k, v in kwargs.items() if k != "benchmark"}),
                               **spec)
    single.reset(seed=1)
    wrapper = single.env
    while not hasattr(wrapper, "residual"):  # the residual wrapper gym.make put on the core
        wrapper = wrapper.env
    assert wrapper.residual.supervisor is None
    with pytest.raises(ValueError, match="supervisor_in_training must be true or false"):
        draw_loops({**V4_SPEC, "supervisor_in_training": "no"}, 0, 0.01)


def test_the_washout_flies_a_step_whole_and_decays_it_at_its_time_constant():
    """Oracle: for a residual held at a from the start, ṁ = (a - m) / τ sampled exactly
    gives m_k = a (1 - e^(-k dt / τ)), so the residual flown, a - m_k, is a e^(-k dt / τ);
    when a returns to zero the flown residual is -m_k."""
    tau, held = 0.25, 0.5
    env = make_vector_env(2, "hover-calm", benchmark="v4", base_controller="geometric-ndob:tuned",
                          residual_mode="acceleration", residual_washout=tau)
    env.reset(seed=[3, 4])
    dt = env.core.scenario.dt
    for k in range(30):
        env.step(np.full((2, 4), held))
        assert env.residual.previous_residual == pytest.approx(held * math.exp(-k * dt / tau))
    env.step(np.zeros((2, 4)))
    assert env.residual.previous_residual == pytest.approx(-held * (1 - math.exp(-30 * dt / tau)))
    env.reset(seed=[3, 4])  # a new episode has nothing washed out yet
    env.step(np.full((2, 4), held))
    assert env.residual.previous_residual == pytest.approx(held)


def test_a_held_residual_moves_the_hover_only_without_the_washout():
    """The observer is told the command, residual included: a constant Δa_z holds the
    vehicle off its reference (m Δa / k_x), and the washout hands that steady part back."""
    offsets = {}
    for washout in (None, 0.3):
        env = make_vector_env(2, "hover-calm", benchmark="v4",
                              base_controller="geometric-ndob:tuned",
                              residual_mode="acceleration", residual_washout=washout)
        env.reset(seed=[3, 4])
        for _ in range(int(4.0 / env.core.scenario.dt)):
            env.step(np.tile([0.0, 0.0, 0.2, 0.0], (2, 1)))  # Δa_z = 0.6 m/s²
        reference = env.core.reference_table[env.core.reference_row, 0]
        offsets[washout] = float(np.mean(env.core.state.position[:, 2] - reference[:, 2]))
    assert offsets[None] > 0.02
    assert abs(offsets[0.3]) < 0.003


def test_a_bad_washout_is_named():
    for bad in (0.0, -1.0, float("nan"), "fast"):
        with pytest.raises(ValueError, match="residual_washout"):
            ResidualOptions(residual_washout=bad)
    assert ResidualOptions(residual_washout=1).keys() == {"residual_washout": 1.0}
