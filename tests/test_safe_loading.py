"""Models load without running code from their files; the shipped one only as recorded;
absurd seed ranges are refused at once."""

import base64
import json
import pathlib
import pickle
import shutil
import zipfile

import numpy as np
import pytest
import torch

from quad_dob_env.dynamics import VehicleState
from quad_dob_env.scenarios import make_scenario
from quad_dob_training import policies
from quad_dob_training.evaluation.evaluate import main as evaluate_main
from quad_dob_training.evaluation.evaluate import parse_seeds
from quad_dob_training.policies import make_policy
from quad_dob_training.rl import model_files
from quad_dob_training.rl.model_files import SHIPPED_RESIDUAL, load_model, pickled_entries
from quad_dob_training.rollout import RECORD_BYTES_PER_STEP, RECORDED_WIDTHS, FlightRecorder


class _Touch:
    """Unpickled, it creates ``marker``: a stand-in for any code a pickle can run."""

    def __init__(self, marker: pathlib.Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return pathlib.Path.touch, (self.marker,)


def _shipped_copy(folder: pathlib.Path) -> pathlib.Path:
    folder.mkdir(parents=True, exist_ok=True)
    for suffix in (".zip", ".yaml"):
        shutil.copy(SHIPPED_RESIDUAL.with_suffix(suffix), folder)
    return folder / SHIPPED_RESIDUAL.name


def _rewrite(path: pathlib.Path, member: str, content: bytes) -> None:
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    members[member] = content
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)


def _craft(path: pathlib.Path, entry: str, marker: pathlib.Path) -> None:
    """``path``'s data with ``entry`` a pickle that creates ``marker``."""
    with zipfile.ZipFile(path) as archive:
        data = json.loads(archive.read("data"))
    data[entry] = {":type:": "<class 'object'>",
                   ":serialized:": base64.b64encode(pickle.dumps(_Touch(marker))).decode()}
    _rewrite(path, "data", json.dumps(data).encode())


def test_a_crafted_zip_runs_no_code_unless_its_pickles_are_trusted(tmp_path):
    # in an entry the loader rebuilds: ignored, the model loads from what the config says
    rebuilt = _shipped_copy(tmp_path / "rebuilt")
    marker = tmp_path / "ran-observation-space"
    _craft(rebuilt, "observation_space", marker)
    model, _ = load_model(rebuilt)
    assert model.observation_space.shape == (40,) and not marker.exists()
    # in an entry it cannot rebuild: refused, naming the entry and the way to allow it
    extra = _shipped_copy(tmp_path / "extra")
    marker = tmp_path / "ran-extra"
    _craft(extra, "custom_thing", marker)
    with pytest.raises(ValueError, match=r"pickled entries .*custom_thing.*--trust-pickle"):
        make_policy(f"residual:{extra}")
    assert not marker.exists()
    # trusted: SB3's own loading, pickles and all
    make_policy(f"residual:{extra}", trust_pickle=True)
    assert marker.exists()


def test_weights_holding_other_pickled_objects_are_refused(tmp_path):
    path = _shipped_copy(tmp_path)
    marker = tmp_path / "ran-weights"
    buffer = tmp_path / "variables.pth"
    torch.save({"payload": _Touch(marker)}, buffer)
    _rewrite(path, "pytorch_variables.pth", buffer.read_bytes())
    with pytest.raises(ValueError, match=r"pytorch_variables\.pth holds pickled objects other "
                                         r"than tensors.*--trust-pickle"):
        load_model(path)
    assert not marker.exists()


def test_a_policy_class_of_another_module_is_not_swapped_silently(tmp_path):
    path = _shipped_copy(tmp_path)
    with zipfile.ZipFile(path) as archive:
        data = json.loads(archive.read("data"))
    data["policy_class"]["__module__"] = "somebody.policies"
    _rewrite(path, "data", json.dumps(data).encode())
    with pytest.raises(ValueError, match=r"policy class from 'somebody.policies'"):
        load_model(path)


def test_the_shipped_policy_flies_as_it_did_when_unpickled():
    with zipfile.ZipFile(SHIPPED_RESIDUAL) as archive:
        entries = pickled_entries(json.loads(archive.read("data")))
    assert {"policy_class", "observation_space", "action_space", "lr_schedule",
            "clip_range", "learning_rate"} <= set(entries)
    assert set(entries) <= set(model_files.REBUILT_ENTRIES)
    safe = make_policy("residual")
    # the old way: every pickled entry unpickled (the shipped file is checked first)
    old, config = load_model(SHIPPED_RESIDUAL, model_files.SHIPPED_RESIDUAL_SHA256,
                             trust_pickle=True)
    trusted = policies.Policy("residual", config["base_controller"], old, config)
    assert safe.model.observation_space == old.observation_space
    assert safe.model.action_space == old.action_space
    assert type(safe.model.policy) is type(old.policy)
    new_weights, old_weights = safe.model.policy.state_dict(), old.policy.state_dict()
    assert new_weights.keys() == old_weights.keys()
    assert all(torch.equal(new_weights[key], old_weights[key]) for key in new_weights)
    observations = np.random.default_rng(0).normal(0.0, 0.3, (6, 40)).astype(np.float32)
    assert np.array_equal(safe.act(observations), trusted.act(observations))


def test_a_changed_shipped_config_is_refused_before_anything_is_read(tmp_path, monkeypatch):
    path = _shipped_copy(tmp_path)
    config = path.with_suffix(".yaml")
    text = config.read_text()
    assert "authority_gate: 0.02" in text
    config.write_text(text.replace("authority_gate: 0.02", "authority_gate: 0.5"))
    monkeypatch.setitem(policies.SHIPPED_POLICIES, "v1",
                        (path, *policies.SHIPPED_POLICIES["v1"][1:]))

    def never(*_):
        raise AssertionError("loaded before its config was checked")

    monkeypatch.setattr(model_files, "algorithm_class", never)
    monkeypatch.setattr(model_files.yaml, "safe_load", never)
    with pytest.raises(ValueError, match=r"training config .*residual_random_tracks\.yaml' "
                                         r"does not match its recorded sha256"):
        make_policy("residual")


def test_absurd_seed_ranges_are_refused_at_once_and_normal_ones_pass(tmp_path):
    assert parse_seeds("9001-9020") == list(range(9001, 9021))
    assert len(parse_seeds("1000")) == 1000
    # each would build a list of 10^8 seeds, or an env of 2 million vehicles, unchecked:
    # a MemoryError or another message, not this one
    for text in ("1-100000000", "100000000"):
        with pytest.raises(ValueError, match=r"100,000,000 flights .* over the memory budget"):
            parse_seeds(text)
    with pytest.raises(ValueError, match="over the memory budget"):
        evaluate_main(["residual"], ["paper-I"], "1-100000000", tmp_path, as_json=True)
    # flying checks each scenario's own length before it builds anything
    with pytest.raises(ValueError, match=r"flying 'hover-calm'.*2,000,000 flights of 1,000 "
                                         r"steps.*over the memory budget"):
        policies.fly_policy(policies.Policy("pid", "pid"), make_scenario("hover-calm"),
                            list(range(2_000_000)))


def test_the_records_cost_no_more_than_they_are_sized_at():
    import tracemalloc

    flight = policies.fly_policy(policies.Policy("pid", "pid"),
                                 make_scenario("hover-calm", duration=0.05), [0])[0]
    for key in RECORDED_WIDTHS:
        assert int(np.prod(getattr(flight, key).shape[1:])) == RECORDED_WIDTHS[key], key
    n, steps = 16, 200
    shapes = {key: getattr(flight, key).shape[1:] for key in RECORDED_WIDTHS}
    record = {key: np.zeros((n, *shape)) for key, shape in shapes.items()}
    state = VehicleState(record["position"], record["velocity"], record["rotation"],
                                  np.zeros((n, 3)))
    ended = np.zeros(n, dtype=bool)
    kept = {k: v for k, v in record.items()
            if k not in ("position", "velocity", "rotation", "acceleration",
                         "requested_rotor_thrusts")}  # the recorder makes the last two
    vehicle = make_scenario("hover-calm").vehicle
    tracemalloc.start()
    recorder = FlightRecorder(n, vehicle)
    for _ in range(steps):
        recorder.add(state, ended, str, requested_moment=np.zeros((n, 3)), **kept)
    flights = recorder.flights([make_scenario("hover-calm")] * n, "pid", 0.01)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert len(flights) == n
    sized = n * steps * RECORD_BYTES_PER_STEP
    assert 0.7 * sized < peak <= sized
