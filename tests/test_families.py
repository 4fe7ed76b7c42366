"""Reference families: each vehicle flies a member drawn from its own seed at every reset."""

from dataclasses import fields

import gymnasium as gym
import numpy as np
import pytest

from quad_dob_composition import make_vector_env
from quad_dob_env import make_scenario
from quad_dob_env.flatness import flat_attitude
from quad_dob_env.trajectories import (
    REFERENCE_FIELDS,
    REFERENCE_KINDS,
    Reference,
    TrajectoryFamily,
    random_references,
)

SHORT = {"duration": 0.3}


def test_the_table_layout_is_the_reference_record_in_order():
    assert tuple(f.name for f in fields(Reference)) == REFERENCE_FIELDS


def test_a_pool_is_seeded_and_bounded_by_the_vehicles_limits():
    first, again, other = (random_references(s, 12) for s in (4, 4, 5))
    times = np.linspace(0.0, 10.0, 101)
    for a, b in zip(first.members, again.members, strict=True):
        assert np.array_equal(a.table(times), b.table(times))
    assert any(not np.array_equal(a.table(times), b.table(times))
               for a, b in zip(first.members, other.members, strict=True))
    assert set(first.kinds) == set(REFERENCE_KINDS)
    for name in ("random-tracks", "random-lemniscates"):
        scenario = make_scenario(name)
        assert scenario.feasibility.feasible  # every member checked, the hardest kept
        # every member keeps v1's 20 % margin on every axis (a draw that does not is redrawn)
        assert min(scenario.feasibility.margins().values()) >= 0.2
    with pytest.raises(ValueError, match=r"reference kind 'spiral'.*valid"):
        random_references(0, 3, kinds=("spiral",))
    with pytest.raises(ValueError, match="one or more Trajectory members"):
        TrajectoryFamily([])


def test_lemniscates_are_held_out_of_the_training_pool():
    training = make_scenario("random-tracks").trajectory
    held_out = make_scenario("random-lemniscates").trajectory
    assert "lemniscate" not in training.kinds and set(held_out.kinds) == {"lemniscate"}


def test_each_vehicle_starts_on_its_own_member_and_draws_anew_at_autoreset():
    env = make_vector_env(16, "random-tracks", scenario_options=SHORT)
    env.reset(seed=0)
    core = env.core
    members = core.reference_member.copy()
    assert len(set(members.tolist())) > 8  # the batch flies different references
    reference = core.reference
    assert np.allclose(core.state.position, reference.position, atol=1e-12)
    assert np.allclose(core.state.velocity, reference.velocity, atol=1e-12)
    # and at the attitude that flies it: a circle starts tilted into its turn
    flat = flat_attitude(reference, core.vehicle.mass, core.vehicle.gravity).rotation
    assert np.allclose(core.state.rotation, flat, atol=1e-12)
    assert not np.allclose(core.state.rotation, np.eye(3))
    for _ in range(31):  # 30 steps end the episodes; the next step autoresets them
        env.step(np.zeros((16, 4)))
    assert not np.array_equal(core.reference_member, members)
    assert np.allclose(core.state.position, core.reference.position, atol=1e-12)


@pytest.mark.slow
def test_same_seed_same_reference_and_wind_bit_for_bit_other_seeds_differ():
    def flight(seed: int) -> np.ndarray:
        env = make_vector_env(3, "random-tracks", scenario_options=SHORT,
                              base_controller="geometric-ndob:tuned")
        obs, _ = env.reset(seed=seed)
        frames = [obs]
        for _ in range(25):
            frames.append(env.step(np.zeros((3, 4)))[0])
        return np.array(frames)

    assert np.array_equal(flight(7), flight(7))
    assert not np.allclose(flight(7), flight(8))


@pytest.mark.slow
def test_native_vector_env_equals_single_envs_on_a_family():
    kwargs = {"num_envs": 3, "scenario": "random-tracks", "scenario_options": SHORT}
    native = gym.make_vec("QuadDOB/TrackResidual-v1", vectorization_mode="vector_entry_point",
                          **kwargs)
    sync = gym.make_vec("QuadDOB/TrackResidual-v1", vectorization_mode="sync", **kwargs)
    obs, _ = native.reset(seed=11)
    obs2, _ = sync.reset(seed=11)
    np.testing.assert_allclose(obs, obs2, rtol=0, atol=1e-5)
    actions = np.random.default_rng(0).uniform(-0.5, 0.5, (70, 3, 4))
    for step in range(70):  # two autoresets each
        obs, rewards, terminated, truncated, _ = native.step(actions[step])
        obs2, rewards2, terminated2, truncated2, _ = sync.step(actions[step].astype(np.float32))
        np.testing.assert_allclose(obs, obs2, rtol=0, atol=1e-5)
        np.testing.assert_allclose(rewards, rewards2, rtol=0, atol=1e-5)
        assert np.array_equal(terminated | truncated, terminated2 | truncated2)


def test_a_spread_start_begins_each_episode_on_a_drawn_point_of_the_reference():
    options = {"reference_start_spread": 2.0, "duration": 0.5}
    env = make_vector_env(8, "dryden-helix-gusts", scenario_options=options)
    env.reset(seed=4)
    core = env.core
    starts = core.reference_start.copy()
    assert len(set(starts.tolist())) > 4 and starts.max() <= 200
    assert (core.step_count == 0).all() and np.all(core.time == 0.0)  # the clock starts at 0
    reference = core.reference
    helix = core.scenario.trajectory.evaluate(starts * core.scenario.dt)
    np.testing.assert_allclose(reference.position, helix.position, atol=1e-12)
    assert np.allclose(core.state.position, reference.position, atol=1e-12)
    assert np.allclose(core.state.velocity, reference.velocity, atol=1e-12)
    flat = flat_attitude(reference, core.vehicle.mass, core.vehicle.gravity).rotation
    assert np.allclose(core.state.rotation, flat, atol=1e-12)
    for _ in range(50):  # past the end of the episode: the table grows as the rows run on
        env.step(np.zeros((8, 4)))
    again = make_vector_env(8, "dryden-helix-gusts", scenario_options=options)
    again.reset(seed=4)
    assert np.array_equal(again.core.reference_start, starts)
    with pytest.raises(ValueError, match="reference_start_spread"):
        make_scenario("dryden-helix", reference_start_spread=-1.0)


def test_helices_and_landings_are_drawn_as_documented():
    pool = random_references(7, 60, kinds=("helix", "landing"))
    times = np.linspace(0.0, 10.0, 1001)
    for member, kind in zip(pool.members, pool.kinds, strict=True):
        table = member.evaluate(times)
        if kind == "helix":
            # a circle in a vertical plane along the heading, within 45° of its top at the
            # start, turning at most at the v1 helix's rate and accelerating at most 6 m/s²
            heading = table.heading[0]
            across = np.array([-heading[1], heading[0], 0.0])
            # the velocity less the drift along the heading lies in the vertical plane
            along = table.velocity @ heading
            circling = table.velocity - along[:, None] * heading
            assert np.abs(circling @ across - np.linalg.norm(circling[:, :2], axis=1)
                          * np.sign(circling @ across)).max() < 1e-9
            assert np.ptp(along) < 1e-9 and 0.0 <= along[0] <= 0.6  # a steady drift
            assert np.linalg.norm(table.acceleration, axis=1).max() <= 6.0 + 1e-9
            top = table.position[:, 2].max()
            assert top - table.position[0, 2] <= (1 - np.cos(np.pi / 4)) * 0.8 + 1e-9
            assert np.all(np.isfinite(table.snap))
        else:
            # take-off from and landing to 8 cm, hovering above one point between
            assert table.position[0, 2] == pytest.approx(0.08)
            assert table.position[-1, 2] == pytest.approx(0.08)
            assert np.ptp(table.position[:, :2], axis=0).max() == 0.0
            assert 0.6 <= table.position[:, 2].max() <= 1.5
    training = make_scenario("random-tracks").trajectory
    assert {"helix", "landing"} <= set(training.kinds)
