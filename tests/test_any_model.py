"""Any model, evaluated: the SB3 adapter built from an env id flies what the id builds; a
zip saved by SB3 (or an rl-zoo3 run) with no project config is evaluated with ``--env``;
rl-zoo3's ``vecnormalize.pkl`` is read without unpickling anything but numpy and SB3's
statistics; bare ``residual`` follows the benchmark flown."""

import json
import os
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
import yaml

import quad_dob_env
from quad_dob_training.cli.commands import main
from quad_dob_training.policies import SHIPPED_POLICIES, resolve_spec
from quad_dob_training.rl import make_sb3_vec_env
from quad_dob_training.rl.foreign_models import read_vecnormalize, read_zoo_yaml, zoo_name

# a short flight keeps every test here fast
SHORT = {"duration": 1.0}
RESIDUAL_ID, DIRECT_ID = "QuadDOB/HoverResidual-v2", "QuadDOB/Hover-v2"


def _ppo(env_id, steps=128, **overrides):
    from stable_baselines3 import PPO

    env = make_sb3_vec_env(env_id, 4, seed=0, scenario_options=SHORT, **overrides)
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=64, n_epochs=1, seed=0,
                device="cpu")
    if steps:
        model.learn(steps)
    return model


@pytest.fixture(scope="module")
def sb3_zip(tmp_path_factory):
    """A PPO made outside the project on the residual v2 id (untrained: what loading
    checks does not depend on training), saved by SB3 alone."""
    path = tmp_path_factory.mktemp("sb3") / "hover.zip"
    _ppo(RESIDUAL_ID, steps=0).save(path)
    return path


@pytest.mark.parametrize("env_id", [DIRECT_ID, RESIDUAL_ID, "QuadDOB/TrackResidual-v1",
                                    "QuadDOB/Hover-v3", "QuadDOB/HoverResidual-v3"])
def test_the_adapter_flies_what_the_ids_own_vector_env_flies(env_id):
    ours = make_sb3_vec_env(env_id, 3, seed=5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium: "-v2 is out of date"
        theirs = gym.make_vec(env_id, 3, vectorization_mode="vector_entry_point")
    assert type(theirs).__name__ == ("ResidualVectorEnv" if quad_dob_env.is_residual_id(env_id)
                                     else "QuadrotorVectorEnv")
    assert ours.observation_space == theirs.single_observation_space
    first, _ = theirs.reset(seed=5)
    np.testing.assert_array_equal(ours.reset(), first)
    rng = np.random.default_rng(0)
    for _ in range(5):
        actions = rng.uniform(-1, 1, (3, 4)).astype(np.float32)
        obs, rewards, dones, _ = ours.step(actions)
        expected, their_rewards, terminated, truncated, _ = theirs.step(actions)
        np.testing.assert_array_equal(obs, expected)
        np.testing.assert_array_equal(rewards, their_rewards.astype(np.float32))
        np.testing.assert_array_equal(dones, terminated | truncated)


def test_the_adapter_refuses_an_unknown_id_and_a_residual_id_without_a_base():
    with pytest.raises(ValueError, match=r"unknown env id 'QuadDOB/Hoover-v2'.*Hover-v2"):
        make_sb3_vec_env("QuadDOB/Hoover-v2", 2)
    with pytest.raises(ValueError, match="residual id: base_controller must name"):
        make_sb3_vec_env(RESIDUAL_ID, 2, base_controller=None)
    with pytest.raises(ValueError, match="direct id and takes no base_controller"):
        make_sb3_vec_env(DIRECT_ID, 2, base_controller="pid")


@pytest.mark.slow
def test_sb3_ppo_trained_outside_the_project_is_evaluated_with_env(tmp_path):
    trained = tmp_path / "hover.zip"
    _ppo(RESIDUAL_ID, steps=256).save(trained)  # learns: SB3 trains on the adapter
    assert not (tmp_path / "config.yaml").exists()
    out = tmp_path / "evaluation"
    assert main(["evaluate", "--policies", f"ppo:{trained},residual", "--env", RESIDUAL_ID,
                 "--scenarios", "hover-calm", "--seeds", "1-2", "--out", str(out),
                 "--scenario-option", "duration=1"]) == 0
    rows = json.loads((out / "evaluation.json").read_text())["rows"]
    # the id supplied the benchmark; bare residual flew that benchmark's shipped policy
    assert [row["policy"] for row in rows[:2]] == ["ppo:hover", "residual:v2"]
    assert rows[0]["provenance"]["benchmark"] == "v2"
    assert rows[0]["provenance"]["env"]["id"] == RESIDUAL_ID
    assert rows[0]["crashes"] == 0


def test_a_zip_without_config_or_env_is_told_to_give_env(sb3_zip, capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{sb3_zip}", "--seeds", "1"])
    assert "give the env id it was trained on with --env" in capsys.readouterr().err


def test_a_benchmark_other_than_the_ids_is_refused_naming_both(sb3_zip, capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{sb3_zip}", "--env", RESIDUAL_ID,
              "--benchmark", "v3", "--seeds", "1"])
    error = capsys.readouterr().err
    assert f"--benchmark v3 disagrees with --env {RESIDUAL_ID}, whose benchmark is v2" in error


def test_a_space_mismatch_is_named(sb3_zip, capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{sb3_zip}", "--env", DIRECT_ID, "--seeds", "1",
              "--json"])
    error = capsys.readouterr().err
    assert "saved with observations of shape (40,)" in error
    assert f"env id {DIRECT_ID}" in error and "has observations of shape (24,)" in error


def test_another_algorithms_name_is_refused(sb3_zip, capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"sac:{sb3_zip}", "--env", RESIDUAL_ID, "--seeds", "1"])
    assert "saved by PPO" in capsys.readouterr().err


def test_a_hand_written_config_naming_the_id_flies_the_ids_env(sb3_zip, tmp_path, capsys):
    """A config naming only the id and algorithm builds the id's env (it used to build the
    default direct env, and fail with a misleading damaged-file error)."""
    folder = tmp_path / "hand"
    folder.mkdir()
    (folder / "model.zip").write_bytes(sb3_zip.read_bytes())
    (folder / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo",
                                                        "env_id": RESIDUAL_ID}))
    assert main(["evaluate", "--policies", f"ppo:{folder}", "--scenarios", "hover-calm",
                 "--seeds", "1", "--json", "--baseline", "", "--scenario-option",
                 "duration=0.5"]) == 0
    (folder / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo",
                                                        "env_id": DIRECT_ID}))
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{folder}", "--seeds", "1", "--json"])
    assert "has observations of shape (24,)" in capsys.readouterr().err


# --- rl-zoo3's files ---------------------------------------------------------------------------

def _vecnormalize(path):
    from stable_baselines3.common.vec_env import VecNormalize

    env = VecNormalize(make_sb3_vec_env(RESIDUAL_ID, 2, seed=0, scenario_options=SHORT),
                       norm_reward=False, clip_obs=7.0)
    env.reset()
    for _ in range(3):
        env.step(np.zeros((2, 4), np.float32))
    env.save(str(path))
    return env


def test_the_restricted_unpickler_reads_a_real_vecnormalize_save(tmp_path):
    saved = _vecnormalize(tmp_path / "vecnormalize.pkl")
    read = read_vecnormalize(tmp_path / "vecnormalize.pkl")
    np.testing.assert_array_equal(read["mean"], saved.obs_rms.mean)
    np.testing.assert_array_equal(read["var"], saved.obs_rms.var)
    assert read["clip"] == 7.0 and read["epsilon"] == saved.epsilon
    assert read == read_vecnormalize(tmp_path / "vecnormalize.pkl", trust_pickle=True)


class _System:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


def test_the_restricted_unpickler_refuses_any_other_class(tmp_path):
    marker = tmp_path / "ran"
    path = tmp_path / "vecnormalize.pkl"
    path.write_bytes(pickle.dumps(_System(marker)))
    with pytest.raises(ValueError, match=r"names (posix|nt)\.system, which reading observation "
                                         r"statistics does not admit.*--trust-pickle"):
        read_vecnormalize(path)
    assert not marker.exists()


def _zoo_run(root, sb3_zip, normalize):
    """An rl-zoo3 run folder as rl-zoo3 lays it out, the model the SB3 one."""
    run = root / f"{zoo_name(RESIDUAL_ID)}_1"
    files = run / zoo_name(RESIDUAL_ID)
    files.mkdir(parents=True)
    (run / f"{zoo_name(RESIDUAL_ID)}.zip").write_bytes(sb3_zip.read_bytes())
    from collections import OrderedDict

    # rl-zoo3 dumps OrderedDicts with yaml.dump: Python tags the safe loader must be taught
    (files / "config.yml").write_text(yaml.dump(OrderedDict(
        [("n_envs", 4), ("normalize", normalize), ("policy", "MlpPolicy")])))
    (files / "args.yml").write_text(yaml.dump(OrderedDict(
        [("algo", "ppo"), ("env", RESIDUAL_ID), ("env_kwargs", None)])))
    return run


def test_zoo_yaml_reads_ordered_dicts_but_no_other_python_object(tmp_path):
    from collections import OrderedDict

    (tmp_path / "a.yml").write_text(yaml.dump(OrderedDict([("normalize", True)])))
    assert read_zoo_yaml(tmp_path / "a.yml") == {"normalize": True}
    (tmp_path / "b.yml").write_text("!!python/object/apply:os.system ['true']\n")
    with pytest.raises(ValueError, match="holds a Python object"):
        read_zoo_yaml(tmp_path / "b.yml")


def test_a_normalised_zoo_run_without_its_vecnormalize_is_refused_naming_it(
        sb3_zip, tmp_path, capsys):
    run = _zoo_run(tmp_path, sb3_zip, "dict(norm_obs=True, norm_reward=False)")
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{run}", "--env", RESIDUAL_ID, "--seeds", "1"])
    error = capsys.readouterr().err
    expected = run / zoo_name(RESIDUAL_ID) / "vecnormalize.pkl"
    assert f"{str(expected)!r}, which holds their statistics, is missing" in error


def test_a_zoo_run_on_another_id_is_refused(sb3_zip, tmp_path, capsys):
    run = _zoo_run(tmp_path, sb3_zip, False)
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{run / (zoo_name(RESIDUAL_ID) + '.zip')}",
              "--env", "QuadDOB/HoverResidual-v3", "--seeds", "1"])
    assert f"rl-zoo3 run on {RESIDUAL_ID}" in capsys.readouterr().err


@pytest.mark.slow
def test_a_normalised_zoo_run_flies_with_its_statistics(sb3_zip, tmp_path):
    from quad_dob_training.policies import make_policy

    run = _zoo_run(tmp_path, sb3_zip, True)
    saved = _vecnormalize(run / zoo_name(RESIDUAL_ID) / "vecnormalize.pkl")
    policy = make_policy(f"ppo:{run}", env_id=RESIDUAL_ID)
    assert policy.config["source"] == "rl-zoo3 run"
    np.testing.assert_array_equal(policy.config["observation_normalization"]["mean"],
                                  saved.obs_rms.mean)
    observations = np.ones((2, 40), np.float32)
    expected, _ = policy.model.predict(saved.normalize_obs(observations), deterministic=True)
    np.testing.assert_allclose(policy.act(observations), expected, atol=1e-6)


# --- names follow the benchmark ----------------------------------------------------------------

def test_bare_residual_is_the_shipped_policy_of_the_benchmark_flown():
    assert [resolve_spec("residual", b) for b in ("v1", "v2", "v3", "v4")] == [
        "residual:v1", "residual:v2", "residual:v3", "residual:v4"]
    newest = f"residual:{list(SHIPPED_POLICIES)[-1]}"
    assert resolve_spec("residual", "v9") == newest  # none trained there: the newest
    assert resolve_spec("residual") == "residual:v1"  # the library's default benchmark
    assert resolve_spec("residual:v1", "v3") == "residual:v1"  # a named one stays itself


def test_the_evaluation_says_which_shipped_policy_to_use_and_why(tmp_path, monkeypatch, capsys):
    from pathlib import Path

    from quad_dob_training.evaluation import evaluate as evaluation
    from quad_dob_training.policies import shipped_policy_advice

    for benchmark in ("v1", "v2", "v3", "v4"):
        advice = shipped_policy_advice(benchmark)
        assert f"in Benchmark {benchmark}: residual:{benchmark}, which bare" in advice
        assert "the loop flown here" in advice
    assert "no shipped policy was trained in Benchmark v9" in shipped_policy_advice("v9")
    source = Path(__file__).parents[1] / "docs/research/transfer-between-benchmarks.md"
    assert source.is_file() and "docs/research/transfer-between-benchmarks.md" in advice
    # with the rows flown: at most three lines, the chosen policy's rows against the
    # baseline, and why a shipped policy that scores lower on a row is not the choice
    flown = [{"scenario": "dryden-helix-gusts", "policy": name, "baseline": "geometric-ndob:tuned",
              "rms_position_settled_mean": rms}
             for name, rms in (("geometric-ndob:tuned", 0.0465), ("residual:v4", 0.0512),
                               ("residual:v3", 0.0450), ("residual:v1", 0.0600))]
    lines = shipped_policy_advice("v4", flown).splitlines()
    assert len(lines) == 3
    assert lines[1] == ("Its rows: dryden-helix-gusts 51.2 mm (+10 % against "
                        "geometric-ndob:tuned).")
    assert "residual:v3 on dryden-helix-gusts (45.0 mm)" in lines[2]
    assert "residual:v1" not in lines[2]

    # the console and report.html carry it when a shipped residual is compared, not otherwise
    def rows(policies, scenarios, seeds, flights, baseline, **_):
        return [{"scenario": "hover-calm", "policy": p, "seeds": "1"} for p in policies]

    monkeypatch.setattr(evaluation, "evaluate", rows)
    monkeypatch.setattr(evaluation, "write_tables", lambda *_: None)
    monkeypatch.setattr(evaluation, "results_document", lambda *_: {})
    monkeypatch.setattr(evaluation, "write_document", lambda *_: None)
    monkeypatch.setattr(evaluation, "evaluation_table", lambda *_: "")  # the console's
    for policies, said in ((["pid", "residual"], True), (["pid", "indi"], False)):
        evaluation.main(policies, ["hover-calm"], "1", tmp_path, False, baseline="pid",
                        scenario_options={"benchmark": "v2"})
        report = (tmp_path / "report.html").read_text()
        printed = capsys.readouterr().out
        assert ("Which shipped policy to use in Benchmark v2: residual:v2" in printed) is said
        assert ("<p class='note'>Which shipped policy" in report) is said


def test_specs_naming_the_same_policy_in_the_benchmark_flown_make_one_row():
    """``residual`` is ``residual:v1`` in v1: the two fly once and make one row (they were
    deduplicated before bare ``residual`` was resolved, and gave two identical rows)."""
    from quad_dob_training.evaluation.evaluate import evaluate

    per_seed: dict = {}
    rows = evaluate(["residual", "residual:v1"], ["hover-calm"], [1], baseline="residual",
                    scenario_options={"benchmark": "v1", "duration": 0.5}, per_seed=per_seed)
    assert [row["policy_spec"] for row in rows] == ["residual:v1"]
    assert rows[0]["baseline"] == "residual:v1"
    # each spec as given still finds its flights
    assert per_seed["hover-calm", "residual"] is per_seed["hover-calm", "residual:v1"]


def test_a_models_baseline_row_and_the_header_name_the_resolved_spec(tmp_path, monkeypatch):
    """A model's rows are named shorter than its spec (``ppo:x``): the baseline row is found
    by its resolved spec; the comparison header names bare ``residual`` as flown."""
    from quad_dob_training.evaluation import evaluate as evaluation

    def rows(policies, scenarios, seeds, flights, baseline, **_):
        return [{"scenario": "hover-calm", "policy": "ppo:x",
                 "policy_spec": "ppo:runs/x/model.zip", "seeds": "1", "crashes": 0,
                 "rms_position_settled_diff_mean": 0.0, "rms_position_settled_diff_low": 0.0,
                 "rms_position_settled_diff_high": 0.0}]

    monkeypatch.setattr(evaluation, "evaluate", rows)
    monkeypatch.setattr(evaluation, "write_tables", lambda *_: None)
    monkeypatch.setattr(evaluation, "results_document", lambda *_: {})
    monkeypatch.setattr(evaluation, "write_document", lambda *_: None)
    monkeypatch.setattr(evaluation, "evaluation_table", lambda *_: "")  # the console's
    evaluation.main(["ppo:runs/x/model.zip"], ["hover-calm"], "1", tmp_path, False,
                    baseline="ppo:runs/x/model.zip", scenario_options={"benchmark": "v3"})
    report = (tmp_path / "report.html").read_text()
    assert report.count("<td>baseline</td>") == 3
    evaluation.main(["pid"], ["hover-calm"], "1", tmp_path, False, baseline="residual",
                    scenario_options={"benchmark": "v3"})
    assert "Δ RMS ‖e_x‖ vs residual:v3 [m]" in (tmp_path / "report.html").read_text()
    # the leaderboard's and markdown's baseline row: compared with nothing
    row = {**rows(0, 0, 0, 0, 0)[0], "rms_position_settled_mean": 0.1, "distinct_flights": 2,
           "flights": 2}
    assert evaluation._difference_cell(row, "ppo:runs/x/model.zip") == "—"


# --- vecnormalize.pkl: what the restricted unpickler admits stays inert -----------------------

def test_a_save_that_does_not_normalise_observations_flies_raw_observations(tmp_path):
    """rl-zoo3's ``normalize: dict(norm_obs=False, norm_reward=True)``: SB3 saves no obs_rms;
    it was refused as "not a VecNormalize save" even with --trust-pickle."""
    from stable_baselines3.common.vec_env import VecNormalize

    env = VecNormalize(make_sb3_vec_env(RESIDUAL_ID, 2, seed=0, scenario_options=SHORT),
                       norm_obs=False, norm_reward=True)
    env.reset()
    env.save(str(tmp_path / "vecnormalize.pkl"))
    assert read_vecnormalize(tmp_path / "vecnormalize.pkl") is None
    assert read_vecnormalize(tmp_path / "vecnormalize.pkl", trust_pickle=True) is None


def _crafted(tmp_path, state):
    """A VecNormalize 'save' whose state is ``state``, pickled with admitted names only
    (the opcodes of ``VecNormalize.__new__`` then ``__setstate__(state)``)."""
    body = pickle.dumps(state, protocol=3)[2:-1]  # less its PROTO and STOP
    path = tmp_path / "vecnormalize.pkl"
    path.write_bytes(b"\x80\x03cstable_baselines3.common.vec_env.vec_normalize\nVecNormalize\n"
                     b")\x81" + body + b"b.")
    return path


@pytest.mark.parametrize("state, named", [
    ({"norm_obs": [1, 2]}, "its norm_obs is a list, not true or false"),
    ({"norm_obs": True}, "norm_obs is true and there is no obs_rms"),
    ({"obs_rms": 3}, "its obs_rms holds no mean and var"),
    ({"obs_rms": {"mean": np.zeros(2), "var": np.ones(2)}, "epsilon": [1e-8]},
     "its epsilon is a list, not a number"),
    ({"obs_rms": {"mean": np.zeros(2), "var": np.ones(2)}, "clip_obs": "ten"},
     "its clip_obs is a str, not a number"),
])
def test_a_crafted_state_is_refused_naming_what_is_wrong(tmp_path, state, named):
    from stable_baselines3.common.running_mean_std import RunningMeanStd

    if isinstance(state.get("obs_rms"), dict):
        rms = RunningMeanStd(shape=(2,))
        state = {**state, "obs_rms": rms}
    with pytest.raises(ValueError, match=named):
        read_vecnormalize(_crafted(tmp_path, state))


def test_admitted_names_given_arguments_build_nothing_that_runs(tmp_path):
    """Payloads made of admitted names only: a REDUCE on a numpy.random name with arguments
    is an inert record (the generator is not made); OrderedDict given arguments is a plain
    dict; ``_reconstruct`` with a subtype that is not an ndarray is refused. Each file is
    refused, naming why, and none runs a thing."""
    from quad_dob_training.rl.foreign_models import ADMITTED, _Record, _RestrictedUnpickler

    def restricted(raw):
        import io

        return _RestrictedUnpickler(io.BytesIO(raw), tmp_path / "x.pkl").load()

    path = tmp_path / "vecnormalize.pkl"
    # numpy.random.default_rng(5): pickle itself makes a Generator, the restricted one a record
    generator = b"\x80\x02cnumpy.random\ndefault_rng\nK\x05\x85R."
    assert type(pickle.loads(generator)).__name__ == "Generator"
    made = restricted(generator)
    assert isinstance(made, _Record) and made.args == (5,) and made.state is None
    path.write_bytes(generator)
    with pytest.raises(ValueError, match="not a VecNormalize save"):
        read_vecnormalize(path)
    # collections.OrderedDict([("norm_obs", True)]): a plain dict, and no save
    ordered = pickle.dumps(__import__("collections").OrderedDict([("norm_obs", True)]),
                           protocol=2)
    assert type(restricted(ordered)) is dict
    path.write_bytes(ordered)
    with pytest.raises(ValueError, match="not a VecNormalize save"):
        read_vecnormalize(path)
    # numpy's _reconstruct(VecNormalize, (0,), b"b"): the record is no ndarray subtype
    module = np.ndarray.__reduce__(np.zeros(1))[0].__module__  # where this numpy keeps it
    subtype = (f"\x80\x02c{module}\n_reconstruct\ncstable_baselines3.common.vec_env."
               "vec_normalize\nVecNormalize\nK\x00\x85C\x01b\x87R.").encode("latin-1")
    path.write_bytes(subtype)
    with pytest.raises(ValueError, match="not a readable VecNormalize save"):
        read_vecnormalize(path)
    # the refusal lists what is admitted, as ADMITTED says
    path.write_bytes(b"\x80\x02cbuiltins\neval\nX\x04\x00\x00\x001+1q\x00\x85R.")
    with pytest.raises(ValueError, match=r"names builtins\.eval") as refused:
        read_vecnormalize(path)
    assert ", ".join(ADMITTED) in str(refused.value)


# --- which config, and which id ---------------------------------------------------------------

def _beside(tmp_path, sb3_zip, config):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "model.zip").write_bytes(sb3_zip.read_bytes())
    (folder / "config.yaml").write_text(yaml.safe_dump(config))
    return folder


FLY = ["--scenarios", "hover-calm", "--seeds", "1", "--json", "--baseline", "",
       "--scenario-option", "duration=0.5"]


def test_another_tools_config_yaml_does_not_override_env(sb3_zip, tmp_path, capsys):
    """A Hydra config.yaml beside the zip is no training config: --env says what the model
    fits (it overrode --env, and the error advised --trust-pickle)."""
    folder = _beside(tmp_path, sb3_zip, {"defaults": ["_self_"], "trainer": {"lr": 3e-4}})
    assert main(["evaluate", "--policies", f"ppo:{folder}", "--env", RESIDUAL_ID, *FLY]) == 0
    assert json.loads(capsys.readouterr().out)[0]["env_id"] == RESIDUAL_ID


def test_a_training_config_naming_another_id_than_env_is_refused_naming_both(
        sb3_zip, tmp_path, capsys):
    folder = _beside(tmp_path, sb3_zip, {"algo": "ppo", "env_id": DIRECT_ID})
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{folder}", "--env", RESIDUAL_ID, *FLY])
    error = capsys.readouterr().err
    assert f"names env_id {DIRECT_ID}, but --env is {RESIDUAL_ID}" in error
    assert "--trust-pickle" not in error
    # the model's own NAME.yaml is its config, whatever config.yaml says
    (folder / "model.yaml").write_text(yaml.safe_dump({"algo": "ppo", "env_id": RESIDUAL_ID}))
    assert main(["evaluate", "--policies", f"ppo:{folder}", "--env", RESIDUAL_ID, *FLY]) == 0


def test_a_config_of_another_algorithm_is_named_without_advising_trust_pickle(
        sb3_zip, tmp_path, capsys):
    folder = _beside(tmp_path, sb3_zip, {"algo": "sac", "env_id": RESIDUAL_ID})
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"sac:{folder}", *FLY])
    error = capsys.readouterr().err
    assert "holds a PPO policy" in error and "names algorithm sac" in error
    assert "--trust-pickle" not in error


def test_a_zoo_run_without_env_flies_the_id_its_args_name(sb3_zip, tmp_path, capsys):
    """rl-zoo3's args.yml says what the run was trained on (it was refused: "no training
    config beside"); its best_model.zip is found beside the same files."""
    run = _zoo_run(tmp_path, sb3_zip, False)
    assert main(["evaluate", "--policies", f"ppo:{run}", *FLY]) == 0
    assert json.loads(capsys.readouterr().out)[0]["env_id"] == RESIDUAL_ID
    (run / "best_model.zip").write_bytes(sb3_zip.read_bytes())
    assert main(["evaluate", "--policies", f"ppo:{run / 'best_model.zip'}", *FLY]) == 0
    assert json.loads(capsys.readouterr().out)[0]["env_id"] == RESIDUAL_ID


def test_a_scenario_option_benchmark_disagreeing_with_env_is_named_as_given(sb3_zip, capsys):
    with pytest.raises(SystemExit):
        main(["evaluate", "--policies", f"ppo:{sb3_zip}", "--env", RESIDUAL_ID,
              "--scenario-option", "benchmark=v3", "--seeds", "1"])
    error = capsys.readouterr().err
    assert (f"--scenario-option benchmark=v3 disagrees with --env {RESIDUAL_ID}, whose "
            "benchmark is v2: leave that option out") in error


def test_evaluation_md_names_the_benchmark_and_which_shipped_policy_to_use(tmp_path):
    out = tmp_path / "evaluation"
    assert main(["evaluate", "--policies", "pid,residual", "--scenarios", "hover-calm",
                 "--seeds", "1", "--benchmark", "v2", "--scenario-option", "duration=2",
                 "--baseline", "", "--out", str(out)]) == 0
    text = (out / "evaluation.md").read_text()
    assert "| hover-calm | residual:v2 |" in text
    assert "Flown in Benchmark v2." in text
    assert "Which shipped policy to use in Benchmark v2: residual:v2" in text


def test_a_zip_named_without_its_suffix_loads_as_sb3_loads_it(sb3_zip, tmp_path):
    bare = str(sb3_zip)[:-len(".zip")]
    assert main(["evaluate", "--policies", f"ppo:{bare}", "--env", RESIDUAL_ID,
                 "--scenarios", "hover-calm", "--seeds", "1", "--baseline", "",
                 "--scenario-option", "duration=1", "--out", str(tmp_path / "e")]) == 0


def test_the_adapter_records_episodes_so_sb3_logs_their_return():
    """Plain SB3 logged no ep_rew_mean: the adapter added no VecMonitor (issue 57)."""
    from stable_baselines3.common.vec_env import VecMonitor

    env = make_sb3_vec_env(RESIDUAL_ID, 2, seed=0, scenario_options=SHORT)
    assert isinstance(env, VecMonitor)
    env.reset()
    returns = np.zeros(2)
    for _ in range(200):
        _, rewards, dones, infos = env.step(np.zeros((2, 4)))
        returns += rewards
        if dones.any():
            break
    assert dones.all()
    episode = infos[0]["episode"]
    assert episode["l"] == 100 and episode["r"] == pytest.approx(returns[0], abs=1e-5)


def test_the_documented_sb3_snippet_trains_and_saves(tmp_path, monkeypatch):
    """docs/evaluate-your-model.md's snippet, run as written on fewer steps."""
    import re
    from pathlib import Path

    page = (Path(__file__).parents[1] / "docs" / "evaluate-your-model.md").read_text()
    snippet = re.search(r"```python\n(.*?)```", page, re.S).group(1)
    assert "model.learn(100_000, progress_bar=True)" in snippet
    assert "torch.set_num_threads(1)" in snippet
    monkeypatch.chdir(tmp_path)
    exec(snippet.replace("model.learn(100_000, progress_bar=True)",
                         "model.learn(4_096, progress_bar=True)"), {})
    assert (tmp_path / "hover_v3.zip").is_file()


def test_two_rl_zoo3_runs_of_one_id_get_their_own_row_names():
    """rl-zoo3 saves every run of an id as <ENV>_<N>/<ENV>.zip: the zip's stem named both
    rows alike (issue 57)."""
    from pathlib import Path

    from quad_dob_training.policies import row_name

    first = Path("logs/ppo/QuadDOB-HoverResidual-v3_1/QuadDOB-HoverResidual-v3.zip")
    second = Path("logs/ppo/QuadDOB-HoverResidual-v3_2/QuadDOB-HoverResidual-v3.zip")
    assert (row_name(first), row_name(second)) == ("QuadDOB-HoverResidual-v3_1",
                                                   "QuadDOB-HoverResidual-v3_2")
    assert row_name(Path("runs/wind/model.zip")) == "wind"
    assert row_name(Path("runs/wind/ppo_200000_steps.zip")) == "ppo_200000_steps"
    assert row_name(Path("mine/hover_v3.zip")) == "hover_v3"


def test_a_zip_records_its_env_id_and_is_refused_under_another(tmp_path, capsys):
    """A zip of the same shape flown under the wrong id was scored silently (issue 57): the
    project's zips record their id; an SB3 zip, which records none, flies with one warning."""
    from quad_dob_training.policies import make_policy
    from quad_dob_training.rl.run_folder import save_model, zip_env_id

    model = _ppo(RESIDUAL_ID, steps=0)
    ours, theirs = tmp_path / "ours.zip", tmp_path / "theirs.zip"
    save_model(model, ours, "run1", RESIDUAL_ID)
    model.save(theirs)
    assert zip_env_id(ours) == RESIDUAL_ID and zip_env_id(theirs) is None
    other = "QuadDOB/HoverResidual-v3"
    with pytest.raises(ValueError, match=rf"was trained on {RESIDUAL_ID} .* not {other}: "
                                         rf"give --env {RESIDUAL_ID}"):
        make_policy(f"ppo:{ours}", trust_pickle=True, env_id=other)
    capsys.readouterr()
    make_policy(f"ppo:{ours}", trust_pickle=True, env_id=RESIDUAL_ID)
    assert capsys.readouterr().err == ""
    make_policy(f"ppo:{theirs}", trust_pickle=True, env_id=other)
    warned = capsys.readouterr().err.splitlines()
    assert len(warned) == 1 and "records no env id" in warned[0] and other in warned[0]
