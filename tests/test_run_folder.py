"""A run folder holds one run: its id in every file it loads again, a lock while it trains,
pickles unpickled only once their run id is checked, the versions it was trained with."""

import base64
import json
import pickle
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import torch
import yaml

from quad_dob_training.learning.train import setup_process, train
from quad_dob_training.rl.checkpoints import (
    STATE_MAGIC,
    latest_checkpoint,
    load_state,
    read_headered,
    write_state,
)
from quad_dob_training.rl.model_files import load_model
from quad_dob_training.rl.run_config import environment_versions, resolve_config
from quad_dob_training.rl.run_folder import RUN_MEMBER, RunLock, zip_run_id

ENV = "QuadDOB/HoverResidual-v1"
QUIET = {"evaluate_every": 10**9, "progress_bar": False}


def _config(tmp_path: Path, seed: int) -> dict:
    conf = tmp_path / "ppo.yml"
    conf.write_text(yaml.safe_dump({ENV: {
        "env_kwargs": {"scenario": "hover-calm"}, "n_envs": 8, "n_timesteps": 512,
        "n_steps": 32, "batch_size": 64, "n_epochs": 1, "policy_kwargs": {"net_arch": [16]}}}))
    return resolve_config("ppo", "residual", ENV, None, None, None, seed, hyperparams=conf)


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> tuple[Path, Path]:
    """Two finished runs of 512 timesteps, each with its checkpoint at 256."""
    folders = []
    for seed in (1, 2):
        out = tmp_path_factory.mktemp(f"run{seed}")
        train(_config(out, seed), out, checkpoint_every=256, **QUIET)
        folders.append(out)
    return folders[0], folders[1]


def _run_id(folder: Path) -> str:
    return yaml.safe_load((folder / "config.yaml").read_text())["run_id"]


def _copy(run: Path, tmp_path: Path, name: str = "copy") -> Path:
    return Path(shutil.copytree(run, tmp_path / name, ignore=shutil.ignore_patterns("tb")))


@pytest.mark.slow
def test_a_run_records_its_id_intervals_and_versions_in_every_file_it_loads_again(runs):
    run = runs[0]
    config = yaml.safe_load((run / "config.yaml").read_text())
    assert len(config["run_id"]) == 32 and config["run_id"] != _run_id(runs[1])
    assert (config["checkpoint_every"], config["evaluate_every"]) == (256, 10**9)
    assert set(config["versions"]) >= {"torch", "numba", "numpy", "stable_baselines3",
                                       "python", "cpu"}
    assert config["versions"] == environment_versions()
    state = run / "checkpoints" / "ppo_256.state"
    assert read_headered(state, STATE_MAGIC, "state").run_id == config["run_id"]
    for model in (run / "model.zip", run / "best_model.zip", state.with_suffix(".zip")):
        assert zip_run_id(model) == config["run_id"]
    assert (run / "run.lock").read_text() == ""  # released at the end


def test_setup_process_sets_the_one_torch_thread_every_run_trains_on():
    # one thread is what makes CPU training bit for bit; deterministic algorithms are left
    # off (they cost seconds per process and guard no op these MLPs use on the CPU)
    torch.set_num_threads(2)
    setup_process()
    assert torch.get_num_threads() == 1


def test_a_second_run_into_a_busy_folder_is_refused_before_it_writes(tmp_path):
    with RunLock(tmp_path / "run"):
        with pytest.raises(ValueError, match=r"is in use by another training \(pid \d+ on .*"
                                             r"started .*wait for it to finish, or train "
                                             "into another --out"):
            train(_config(tmp_path, 1), tmp_path / "run", **QUIET)
        assert [p.name for p in (tmp_path / "run").iterdir()] == ["run.lock"]


def test_the_lock_of_a_killed_process_is_taken_over(tmp_path, capsys):
    folder = tmp_path / "run"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys\nfrom quad_dob_training.rl.run_folder import RunLock\n"
         f"with RunLock({str(folder)!r}):\n    print('held', flush=True)\n    sys.stdin.read()"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        with pytest.raises(ValueError, match=f"pid {holder.pid} on"), RunLock(folder):
            pass
    finally:
        holder.kill()  # SIGKILL: it never releases, the kernel does
        holder.wait()
        holder.stdin.close()
        holder.stdout.close()
    assert f'"pid": {holder.pid}' in (folder / "run.lock").read_text()
    with RunLock(folder):
        assert f'"pid": {holder.pid}' not in (folder / "run.lock").read_text()
    assert f"did not end cleanly (pid {holder.pid} on" in capsys.readouterr().out


def test_a_checkpoint_pair_mixed_from_two_runs_is_refused(runs, tmp_path):
    mixed = _copy(runs[0], tmp_path)
    state = mixed / "checkpoints" / "ppo_256.state"
    shutil.copy(runs[1] / "checkpoints" / "ppo_256.zip", state.with_suffix(".zip"))
    with pytest.raises(ValueError, match=rf"'{state}' is of run {_run_id(runs[0])} but "
                                         rf"'{state.with_suffix('.zip')}' beside it is of run "
                                         rf"{_run_id(runs[1])}: the pair mixes two runs"):
        train(None, mixed, resume=mixed, progress_bar=False)


def _probe(marker: Path) -> bytes:
    """A pickle that, unpickled, creates ``marker``: proof of whether anything unpickled it."""
    class Touch:
        def __reduce__(self):
            return (Path.touch, (marker,))
    return pickle.dumps(Touch())


def test_a_state_in_another_runs_folder_is_refused_without_being_unpickled(runs, tmp_path):
    folder = _copy(runs[0], tmp_path)
    state = folder / "checkpoints" / "ppo_256.state"
    other = _run_id(runs[1])
    config = yaml.safe_load((folder / "config.yaml").read_text())
    (folder / "config.yaml").write_text(yaml.safe_dump({**config, "run_id": other}))
    marker = tmp_path / "unpickled"
    header = read_headered(state, STATE_MAGIC, "state").header
    state.write_bytes(STATE_MAGIC + json.dumps(header).encode() + b"\n" + _probe(marker))
    with pytest.raises(ValueError, match=rf"'{state}' is of run {_run_id(runs[0])} but "
                                         rf"'{folder / 'config.yaml'}' is of run {other}"):
        train(None, tmp_path / "resumed", resume=state, progress_bar=False)
    # an old-style (header-less) pickle beside an id-less zip is no way around the check
    state.write_bytes(_probe(marker))
    _drop_run_member(state.with_suffix(".zip"))
    with pytest.raises(ValueError, match=rf"'{state}' is of run None but .* is of run {other}"):
        load_state(state)
    # and a state with no config.yaml to vouch for it needs --trust-pickle
    (folder / "config.yaml").unlink()
    state.write_bytes(STATE_MAGIC + json.dumps(header).encode() + b"\n" + _probe(marker))
    shutil.copy(runs[0] / "checkpoints" / "ppo_256.zip", state.with_suffix(".zip"))
    with pytest.raises(ValueError, match=r"no config.yaml in its run folder.*--trust-pickle"):
        load_state(state)
    assert not marker.exists()
    pickle.loads(_probe(marker))  # the probe works: had it been unpickled, it would show
    assert marker.exists()


def _drop_run_member(path: Path) -> None:
    with zipfile.ZipFile(path) as bundle:
        members = {name: bundle.read(name) for name in bundle.namelist() if name != RUN_MEMBER}
    with zipfile.ZipFile(path, "w") as bundle:
        for name, data in members.items():
            bundle.writestr(name, data)


def test_an_old_checkpoint_without_run_id_resumes_with_a_warning(runs, tmp_path):
    """As written before run ids: a plain pickle of a state without run id, intervals or
    evaluation rows, a zip without the member, a config.yaml without run id."""
    old = _copy(runs[0], tmp_path)
    state_path = old / "checkpoints" / "ppo_256.state"
    state = load_state(state_path)
    for key in ("run_id", "checkpoint_every", "evaluate_every"):
        state["config"].pop(key)
    for key in ("rows", "last"):
        state["callbacks"][0].pop(key)
    state_path.write_bytes(pickle.dumps(state))
    _drop_run_member(state_path.with_suffix(".zip"))
    config = yaml.safe_load((old / "config.yaml").read_text())
    config.pop("run_id")
    (old / "config.yaml").write_text(yaml.safe_dump(config))
    with pytest.warns(UserWarning, match=rf"'{state_path}' has no run id"):
        model = train(None, old, resume=old, progress_bar=False)
    assert model.num_timesteps == 512
    original = load_model(runs[0] / "model.zip")[0].policy.state_dict()
    assert all(torch.equal(original[k], v) for k, v in model.policy.state_dict().items())
    rows = (old / "evaluations.csv").read_text().splitlines()
    assert rows == (runs[0] / "evaluations.csv").read_text().splitlines()


@pytest.mark.slow
def test_a_resume_with_other_versions_warns_that_it_is_no_longer_bit_for_bit(runs, tmp_path):
    folder = _copy(runs[0], tmp_path)
    state_path = latest_checkpoint(folder)
    state = load_state(state_path)
    state["config"]["versions"] = {**state["config"]["versions"], "torch": "0.0.1",
                                   "cpu": "an abacus"}
    write_state(state_path, state)
    with pytest.warns(UserWarning, match=r"torch 0\.0\.1 -> .*cpu an abacus -> .*no longer "
                                         "bit for bit"):
        train(None, folder, resume=state_path, progress_bar=False)


class _Touch:
    """Unpickled, it creates ``marker``: a stand-in for any code a pickle can run."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return Path.touch, (self.marker,)


@pytest.mark.slow
def test_a_bare_model_from_anywhere_trains_on_from_its_weights_unpickled(runs, tmp_path):
    stray = tmp_path / "downloads"
    stray.mkdir()
    crafted, marker = stray / "model.zip", tmp_path / "ran"
    with zipfile.ZipFile(runs[0] / "model.zip") as source, \
            zipfile.ZipFile(crafted, "w") as target:
        for item in source.infolist():
            content = source.read(item.filename)
            if item.filename == "data":  # every pickled entry a payload
                data = json.loads(content)
                for value in data.values():
                    if isinstance(value, dict) and ":serialized:" in value:
                        value[":serialized:"] = base64.b64encode(
                            pickle.dumps(_Touch(marker))).decode()
                content = json.dumps(data).encode()
            target.writestr(item, content)
    config = _config(tmp_path, 3)
    model = train(config, tmp_path / "more", resume=crafted, **QUIET)
    assert not marker.exists()  # nothing in the zip was unpickled
    assert model.num_timesteps == 1024  # its 512 timesteps counted on
    before = load_model(runs[0] / "model.zip")[0].policy.state_dict()
    after = model.policy.state_dict()
    assert any(not torch.equal(before[k], after[k]) for k in before)  # trained on
    with pytest.raises(ValueError, match=r"do not fit the network the run's config builds"):
        train({**_config(tmp_path, 4), "policy_kwargs": {"net_arch": [8]}}, tmp_path / "x",
              resume=crafted, **QUIET)


def test_a_model_beside_another_runs_config_is_refused(runs, tmp_path):
    folder = _copy(runs[0], tmp_path)
    config = yaml.safe_load((folder / "config.yaml").read_text())
    model_id = config["run_id"]
    # a newer run began here and was killed before it wrote its model
    (folder / "config.yaml").write_text(yaml.safe_dump({**config, "run_id": "newer"}))
    with pytest.raises(ValueError, match=rf"is of run {model_id} but .*config.yaml' beside it "
                                         r"is of run newer"):
        load_model(folder / "model.zip")


def test_buffers_past_the_memory_budget_are_refused_before_sb3_allocates_them():
    from types import SimpleNamespace

    import gymnasium as gym

    from quad_dob_training.learning.train import check_buffer_memory

    venv = SimpleNamespace(observation_space=gym.spaces.Box(-1, 1, (40,)),
                           action_space=gym.spaces.Box(-1, 1, (4,)))
    ppo = {"algo": "ppo", "n_envs": 4096, "algo_kwargs": {"n_steps": 64}}
    check_buffer_memory(ppo, venv)  # 4096 x 64 steps: 104 MiB
    with pytest.raises(ValueError, match=r"PPO's rollout buffer of 65,536 vehicles x n_steps "
                                         r"2,048 would take 50 GiB"):
        check_buffer_memory({**ppo, "n_envs": 65_536, "algo_kwargs": {}}, venv)  # SB3's 2048
    with pytest.raises(ValueError, match=r"SAC's replay buffer of 100,000,000 transitions "
                                         r"would take 32.4 GiB.*a smaller buffer_size"):
        check_buffer_memory({"algo": "sac", "n_envs": 1,
                             "algo_kwargs": {"buffer_size": 10**8}}, venv)


def test_a_run_resumed_into_another_folder_is_a_copy_with_its_own_id(runs, tmp_path):
    source = _copy(runs[0], tmp_path)
    elsewhere = tmp_path / "elsewhere"
    train(None, elsewhere, resume=source / "checkpoints" / "ppo_256.state", progress_bar=False)
    assert _run_id(elsewhere) not in (None, _run_id(source))
    assert zip_run_id(elsewhere / "model.zip") == _run_id(elsewhere)
    # the same computation as the run that never stopped
    first = load_model(source / "model.zip")[0].policy.state_dict()
    second = load_model(elsewhere / "model.zip")[0].policy.state_dict()
    assert all(torch.equal(first[k], second[k]) for k in first)
