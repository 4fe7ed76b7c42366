"""The vehicle loop as data (issue 52): the compiled kernels take records read by field and
one loop flies an inner loop's ticks (tests/test_layering.py holds every compiled function
to 20 parameters)."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import quad_dob_env  # noqa: F401  (registers the ids)

ROOT = Path(__file__).resolve().parent.parent


def _parameters(kernel) -> list[str]:
    return list(inspect.signature(kernel.py_func).parameters)


def test_entry_kernels_take_their_records_fields_in_order():
    # the records are built by keyword and spread into the kernels as plain tuples: a
    # kernel whose parameters drifted from its record's fields would take one for another
    from quad_dob_composition.attitude_loop import attitude_loop_kernel
    from quad_dob_env.envs.step_kernels import (
        StartArguments,
        StepArguments,
        named_step,
        start_kernel,
        step_kernel,
    )

    assert _parameters(step_kernel) == ["start", "stop", "actions", *StepArguments._fields]
    assert _parameters(named_step) == list(StepArguments._fields)
    assert _parameters(attitude_loop_kernel) == ["start", "stop", "actions", "addition",
                                                 "inner_law", *StepArguments._fields]
    assert _parameters(start_kernel) == ["indices", "offsets", "rotations", "scales",
                                         *StartArguments._fields]


@pytest.mark.parametrize("env_id", ["QuadDOB/Track-v1", "QuadDOB/Hover-v3"])
def test_the_plain_tuples_name_back_to_the_same_records(env_id):
    # what crosses into compiled code is the record's values in field order, and
    # ``named_step`` (run here as Python) gives each record its class back
    from quad_dob_env.envs.step_kernels import kernel_tuples, named_step

    env = gym.make(env_id)
    env.reset(seed=0)
    arguments = env.unwrapped.core.step_arguments()
    named = named_step.py_func(*kernel_tuples(arguments))
    assert type(named) is type(arguments)
    for field in arguments._fields:
        given, back = getattr(arguments, field), getattr(named, field)
        assert type(back) is type(given), field
        for name in given._fields:
            assert getattr(back, name) is getattr(given, name), f"{field}.{name}"


def test_composition_flies_no_loop_over_ticks():
    # the one loop over an inner loop's ticks is quad_dob_env.envs.step_kernels.fly_vehicles;
    # the attitude loop hands it a law
    tree = ast.parse((ROOT / "composition" / "attitude_loop.py").read_text())
    loops = [ast.unparse(node.iter) for node in ast.walk(tree)
             if isinstance(node, (ast.For, ast.While))]
    assert not loops, loops
    kernels = ast.parse((ROOT / "quad_dob_env" / "envs" / "step_kernels.py").read_text())
    tick_loops = [node for node in ast.walk(kernels)
                  if isinstance(node, ast.For) and "ticks" in ast.unparse(node.iter)]
    assert len(tick_loops) == 1


def test_an_action_map_record_commands_what_the_action_map_does():
    # the records reach the kernels by field: the env's compiled command agrees with the
    # action map's own (a swapped scale would not)
    env = gym.make("QuadDOB/Track-v1")
    env.reset(seed=0)
    action_map = env.unwrapped.core.action_map
    actions = np.array([[0.5, -0.3, 0.2, -1.0], [-0.7, 0.9, -0.1, 0.4]])
    thrust, moment = action_map.to_command(actions)
    rotor_mode, centre, scale_up, scale_down, allocation = action_map.forward
    for row, action in enumerate(actions):
        values = centre + action * np.where(action >= 0.0, scale_up, scale_down)
        expected = allocation @ values if rotor_mode else values
        np.testing.assert_allclose([thrust[row], *moment[row]], expected, rtol=1e-12)
