"""``ResidualOptions``: the presets are the shipped policies' options, flat keys become the
record in one place, and bad options are named."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from quad_dob_env.residual import OPTION_NAMES, RESIDUAL_PRESETS, ResidualOptions
from quad_dob_env.residual.options import split_residual_keys

PRETRAINED = Path(__file__).parents[1] / "training" / "pretrained"
SHIPPED = {"residual:v1": "residual_random_tracks.yaml", "residual:v2": "residual_v2.yaml",
           "residual:v3": "residual_v3.yaml", "residual:v4": "residual_v4.yaml"}


@pytest.mark.parametrize("name", list(SHIPPED))
def test_each_preset_is_its_shipped_policys_options(name):
    env_kwargs = yaml.safe_load((PRETRAINED / SHIPPED[name]).read_text())["env_kwargs"]
    flat = {key: value for key, value in env_kwargs.items() if key in OPTION_NAMES}
    assert ResidualOptions.from_keys(flat) == RESIDUAL_PRESETS[name]


def test_flat_keys_leave_the_env_options_and_a_record_takes_them_over():
    kwargs = {"thrust_scale": 0.2, "scenario": "hover-calm"}
    options = split_residual_keys(kwargs, RESIDUAL_PRESETS["residual:v2"])
    assert kwargs == {"scenario": "hover-calm"}
    assert options.thrust_scale == 0.2 and options.authority_signal == "wind"


@pytest.mark.parametrize(("keys", "named"), [({"thrust_scale": 1.5}, "thrust_scale"),
                                             ({"residual_mode": "jerk"}, "residual_mode"),
                                             ({"floor_fade": (0.5, 0.2)}, "floor_fade"),
                                             ({"thrust_scal": 0.1}, "thrust_scale")])
def test_bad_options_are_named(keys, named):
    with pytest.raises(ValueError, match=named):
        ResidualOptions.from_keys(keys)


def test_the_record_is_frozen():
    with pytest.raises(AttributeError):
        ResidualOptions().thrust_scale = 0.5  # type: ignore[misc]
