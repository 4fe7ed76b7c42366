"""The observation table (quad_dob_env.envs.observation) against what the kernels write:
each named entry's columns hold what its name says, computed here from the state, the
reference and the base's command, for both rotation representations, with and without
the residual's entries."""

import numpy as np
import pytest

from quad_dob_composition import make_vector_env
from quad_dob_env.envs import TERMINATION_REASONS, TIME_LIMIT, TerminationCode
from quad_dob_env.envs.observation import observation_table
from quad_dob_env.envs.quadrotor_env import QuadrotorEnv
from quad_dob_env.residual import ResidualOptions


def _expected(env, representation):
    """Each entry's values from its definition, (N, size) each, by name."""
    core = env.core
    m = core.measurement
    reference = core.reference
    R = m.rotation
    rotation = (R.reshape(-1, 9) if representation == "matrix"
                else np.concatenate([R[:, :, 0], R[:, :, 1]], axis=1))
    expected = {
        "position_error": m.position - reference.position,
        "velocity_error": m.velocity - reference.velocity,
        "rotation": rotation,
        "body_rates": m.angular_velocity,
        "desired_acceleration": reference.acceleration,
        "desired_heading": reference.heading,
    }
    residual = getattr(env, "residual", None)
    if residual is not None:
        body = np.einsum("nji,nj->ni", R, m.position - reference.position)
        limit = core.action_map.to_command(np.ones((1, 4)))[1][0]  # the moment limit
        expected.update({
            "base_command": core.action_map.to_actions(residual.base_thrust,
                                                       residual.base_moment),
            "force_estimate": residual.force_estimate / (core.vehicle.mass
                                                         * core.vehicle.gravity),
            "torque_estimate": residual.torque_estimate / limit,
            "body_position_error": body,
            "body_velocity_error": np.einsum("nji,nj->ni", R, m.velocity - reference.velocity),
        })
    return expected


@pytest.mark.parametrize("representation", ["matrix", "6d"])
@pytest.mark.parametrize("options", [
    None,  # the env alone
    {},  # the residual's entries
    {"authority_gate": 0.05, "floor_fade": (0.3, 0.6)},  # the same with the gate and fade
])
def test_each_entry_holds_what_its_name_says(representation, options):
    residual = None if options is None else ResidualOptions(**options)
    kwargs = {} if options is None else {"base_controller": "geometric-ndob", **options}
    env = make_vector_env(3, "dryden-helix", rotation_representation=representation, **kwargs)
    table = observation_table(representation, residual)
    assert sum(entry.size for entry in table) == env.single_observation_space.shape[0]
    # one after another, no gaps, each name once
    assert [entry.columns.start for entry in table] == \
        [0, *np.cumsum([entry.size for entry in table])[:-1]]
    assert len({entry.name for entry in table}) == len(table)
    obs, _ = env.reset(seed=[1, 2, 3])
    actions = np.tile(np.float32([0.3, -0.2, 0.1, 0.05]), (3, 1))
    for _ in range(12):
        obs, *_ = env.step(actions)
    expected = _expected(env, representation)
    assert set(expected) == {entry.name for entry in table}
    for entry in table:
        np.testing.assert_allclose(obs[:, entry.columns], expected[entry.name], rtol=1e-5,
                                   atol=1e-6, err_msg=entry.name)
        low, high = entry.bounds
        assert np.all((obs[:, entry.columns] >= low) & (obs[:, entry.columns] <= high))
    # a wrong equation shows: these entries move during a flight
    assert np.abs(obs[:, table[0].columns]).max() > 1e-4


def test_the_single_env_has_the_vector_envs_table():
    env = QuadrotorEnv("hover-calm", rotation_representation="6d")
    assert env.observation_space.shape[0] == sum(e.size for e in observation_table("6d"))
    with pytest.raises(ValueError, match=r"unknown rotation_representation 'quat'.*6d"):
        observation_table("quat")


def test_entries_have_no_columns_until_placed():
    from quad_dob_env.envs.observation import env_entries
    with pytest.raises(ValueError, match="no columns until placed"):
        _ = env_entries()[0].columns


def test_termination_codes_name_the_reasons_info_reports():
    assert TERMINATION_REASONS == ("", "crashed", "out_of_bounds", "attitude_lost",
                                   "non_finite_state", "invalid_action")
    assert TerminationCode.CRASHED.reason == "crashed" and not TerminationCode.FLYING.reason
    assert TIME_LIMIT not in TERMINATION_REASONS  # a truncation, not a code


@pytest.mark.parametrize(("start", "code"), [
    ({"initial_position": (0.0, 0.0, 0.05)}, TerminationCode.CRASHED),  # thrust cut
    ({"initial_position": (0.0, 0.0, 8.0)}, TerminationCode.OUT_OF_BOUNDS),
    ({"initial_angular_velocity": (40.0, 0.0, 0.0)}, TerminationCode.ATTITUDE_LOST),
])
def test_each_limit_ends_the_episode_with_its_code(start, code):
    from quad_dob_env.scenarios import make_scenario
    scenario = make_scenario("ground-effect-landing", **start)
    env = make_vector_env(1, scenario)
    env.reset(seed=0)
    for _ in range(50):
        _, _, terminated, _, info = env.step(np.float32([[-1.0, 0.0, 0.0, 0.0]]))
        if terminated[0]:
            break
    assert terminated[0] and env.core.termination_code[0] == code
    assert info["termination_reason"][0] == code.reason


def _docstring_rows(text, header):
    """(first column, last column, unit) of each row of the markdown table after
    ``header`` in ``text``."""
    lines = text[text.index(header):].splitlines()
    rows = []
    for line in lines[1:]:
        line = line.strip()
        if not line.startswith("|"):
            if rows:
                break
            continue
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        first = cells[0].split()[0]  # "6-14 (6-11)": the matrix layout's
        if not first[0].isdigit():
            continue
        low, _, high = first.partition("-")
        rows.append((int(low), int(high or low), cells[-1]))
    return rows


def test_the_docstrings_tables_are_the_code_table():
    from quad_dob_env.residual import command
    env_rows = _docstring_rows(QuadrotorEnv.__doc__, "## Observation space")
    assert env_rows == [(e.columns.start, e.columns.stop - 1, e.unit)
                        for e in observation_table("matrix")]
    always = observation_table("matrix", ResidualOptions())[len(env_rows):]
    residual_rows = _docstring_rows(command.__doc__, "| index (after the env's)")
    offset = always[0].columns.start
    assert residual_rows[:len(always)] == [(e.columns.start - offset, e.columns.stop - 1 - offset,
                                            e.unit) for e in always]
