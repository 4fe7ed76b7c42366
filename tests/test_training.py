import json

import numpy as np
import pytest

from quad_dob_composition import make_vector_env
from quad_dob_env.envs import QuadrotorVectorEnv
from quad_dob_training import cli
from quad_dob_training.evaluation.evaluate import evaluate, parse_seeds
from quad_dob_training.learning.train import train
from quad_dob_training.policies import check_spaces, make_policy
from quad_dob_training.rl.model_files import load_model, sha256
from quad_dob_training.rl.run_config import resolve_config


def _tiny(mode: str, env_id: str, **options):
    config = resolve_config("ppo", mode, env_id, "hover-calm", 256, 8, seed=3, **options)
    config["algo_kwargs"].update(n_steps=32, batch_size=64, n_epochs=1)
    return config


@pytest.fixture(scope="module")
def residual_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("residual")
    train(_tiny("residual", "QuadDOB/HoverResidual-v1"), out, evaluate_every=10**9,
          progress_bar=False)
    return out


@pytest.mark.slow
def test_train_save_load_evaluate_round_trip(residual_run, capsys):
    files = {p.name for p in residual_run.iterdir()}
    assert {"model.zip", "config.yaml", "evaluations.csv", "tb", "train.log",
            "training_curve.png", "best_model.zip", "best_model.yaml"} <= files
    assert "timesteps/s" in (residual_run / "train.log").read_text()
    model, config = load_model(residual_run / "model.zip")
    assert config["mode"] == "residual" and config["base_controller"] == "geometric-ndob:tuned"
    assert model.observation_space.shape == (40,)
    rows = evaluate(["geometric-ndob:tuned", f"residual:{residual_run}"], ["gusty-hover"],
                    parse_seeds("2"))
    assert [row["policy"] for row in rows] == ["geometric-ndob:tuned", "residual:" +
                                               residual_run.name]
    for row in rows:
        assert np.isfinite(row["rms_position_settled_mean"]) and 0 <= row["crash_rate"] <= 1
    assert cli.main(["evaluate", "--policies", f"pid,ppo:{residual_run / 'model.zip'}",
                     "--scenarios", "hover-calm", "--seeds", "7-8", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert {(r["scenario"], r["policy"]) for r in printed} == {
        ("hover-calm", "pid"), ("hover-calm", f"ppo:{residual_run.name}")}


@pytest.mark.slow
def test_a_bare_model_trains_on_for_more_timesteps(residual_run, tmp_path):
    config = _tiny("residual", "QuadDOB/HoverResidual-v1")
    model = train(config, tmp_path, resume=residual_run / "model.zip", evaluate_every=10**9,
                  progress_bar=False)
    assert model.num_timesteps >= 2 * 256


@pytest.mark.slow
def test_a_model_in_an_env_with_other_spaces_fails_before_any_step(residual_run, tmp_path):
    policy = make_policy(f"residual:{residual_run}")
    direct_env = QuadrotorVectorEnv(1, "hover-calm")  # 24 observations, not 40
    with pytest.raises(ValueError, match=r"expects observations \(40,\).*gives observations "
                                         r"\(24,\)"):
        check_spaces(policy, direct_env)
    direct = tmp_path / "direct"
    train(_tiny("direct", "QuadDOB/Hover-v1"), direct, evaluate_every=10**9,
          progress_bar=False)
    with pytest.raises(ValueError, match="trained in mode 'direct', not 'residual'"):
        make_policy(f"residual:{direct}")


def test_the_shipped_policy_loads_after_its_checksum_and_fits_its_env():
    policy = make_policy("residual")
    assert policy.base == "geometric-ndob:tuned"
    env = make_vector_env(2, "dryden-helix-gusts", **policy.env_kwargs())
    check_spaces(policy, env)
    obs, _ = env.reset(seed=0)
    assert policy.act(obs).shape == (2, 4)


def test_model_files_are_checked_before_loading(residual_run, tmp_path):
    path = residual_run / "model.zip"
    assert load_model(path, sha256(path))[1]["mode"] == "residual"
    with pytest.raises(ValueError, match="does not match its recorded sha256"):
        load_model(path, "0" * 64)
    with pytest.raises(ValueError, match="does not exist"):
        load_model(tmp_path / "missing.zip")
    lonely = tmp_path / "lonely.zip"
    lonely.write_bytes(path.read_bytes())
    with pytest.raises(ValueError, match="no training config beside"):
        load_model(lonely)


def test_bad_training_and_evaluation_input_is_named():
    with pytest.raises(ValueError, match="does not fit env"):
        resolve_config("ppo", "residual", "QuadDOB/Track-v1", None, 10, 1, 0)
    with pytest.raises(ValueError, match=r"env id 'QuadDOB/Track-v9'.*valid"):
        resolve_config("ppo", "direct", "QuadDOB/Track-v9", None, 10, 1, 0)
    with pytest.raises(ValueError, match=r"algorithm 'ddpg'.*ppo, sac, td3"):
        resolve_config("ddpg", "direct", "QuadDOB/Track-v1", None, 10, 1, 0)
    assert parse_seeds("3") == [0, 1, 2] and parse_seeds("9001-9020")[-1] == 9020
    with pytest.raises(ValueError, match="inclusive range"):
        parse_seeds("20-10")
    with pytest.raises(ValueError, match=r"policy 'ppo'.*valid"):
        make_policy("ppo")


@pytest.mark.slow
def test_normalised_observations_travel_with_the_model(tmp_path):
    config = _tiny("residual", "QuadDOB/HoverResidual-v1")
    config["normalize"] = {"norm_obs": True, "norm_reward": False}
    train(config, tmp_path, evaluate_every=10**9, progress_bar=False)
    policy = make_policy(f"residual:{tmp_path}")
    statistics = policy.config["observation_normalization"]
    assert len(statistics["mean"]) == 40 and min(statistics["var"]) >= 0
    observations = np.zeros((3, 40), np.float32)
    assert policy.act(observations).shape == (3, 4)


@pytest.mark.slow
def test_the_shipped_residual_beats_its_base_in_gusty_turbulence():
    # a guard on the shipped policy: five of the 20 seeds of
    # docs/research/residual-v1-generalist.md's table (seen when v1's design was chosen)
    rows = evaluate(["geometric-ndob:tuned", "residual"], ["dryden-helix-gusts"],
                    parse_seeds("9001-9005"))
    base, residual = rows
    assert residual["crash_rate"] <= base["crash_rate"]
    assert residual["rms_position_settled_mean"] < 0.75 * base["rms_position_settled_mean"]
    # paired over the seeds, the 95 % interval of the difference lies below zero
    assert residual["rms_position_settled_diff_high"] < 0 == base["rms_position_settled_diff_mean"]


@pytest.mark.slow
def test_the_shipped_residual_stays_out_of_the_way_in_calm_air():
    # the generalist's authority gate: where the observer sees no disturbance it flies its
    # base exactly, so its calm scores are the base's to the last bit
    rows = evaluate(["geometric-ndob:tuned", "residual"], ["hover-calm", "paper-none"],
                    parse_seeds("9001-9003"))
    for base, residual in zip(rows[::2], rows[1::2], strict=True):
        # bare residual flies the library benchmark's (v1's) shipped policy, named as resolved
        assert residual["policy"] == "residual:v1" and base["scenario"] == residual["scenario"]
        assert residual["rms_position_settled_mean"] == base["rms_position_settled_mean"]


def test_a_typo_in_the_hyperparameter_file_is_named(tmp_path):
    hyperparams = tmp_path / "ppo.yml"
    hyperparams.write_text("QuadDOB/Track-v1:\n  n_step: 64\n")
    with pytest.raises(ValueError, match=r"key in ppo.yml \[QuadDOB/Track-v1\] 'n_step'.*"
                                         r"did you mean 'n_steps'"):
        resolve_config("ppo", "direct", "QuadDOB/Track-v1", None, 10, 1, 0,
                       hyperparams=hyperparams)


def test_a_cut_off_or_corrupted_model_is_named_not_a_deep_traceback(tmp_path):
    from quad_dob_training.rl.model_files import SHIPPED_RESIDUAL, load_model

    cut = tmp_path / "model.zip"
    cut.write_bytes(SHIPPED_RESIDUAL.read_bytes()[:5000])  # killed while writing
    (tmp_path / "config.yaml").write_text("mode: residual\n")
    with pytest.raises(ValueError, match=r"model\.zip' is not a stable-baselines3 zip"):
        load_model(cut)
    # a whole zip whose policy weights are garbage
    import zipfile

    broken = tmp_path / "broken.zip"
    with zipfile.ZipFile(SHIPPED_RESIDUAL) as source, zipfile.ZipFile(broken, "w") as target:
        for item in source.namelist():
            data = source.read(item)
            target.writestr(item, b"not torch" if item == "policy.pth" else data)
    (tmp_path / "broken.yaml").write_text("mode: residual\n")
    with pytest.raises(ValueError, match=r"broken\.zip' could not be loaded .*damaged"):
        load_model(broken)


def test_evaluation_records_each_state_with_the_desired_attitude_asked_for_it():
    # the compiled residual pass overwrites the controller's diagnostics in place each step:
    # flown through it, a base must still be recorded as the plain controller loop records
    # it (rollout.fly, whose controller makes new arrays each step), step for step
    from quad_dob_baselines import make_controller
    from quad_dob_env.scenarios import make_scenario
    from quad_dob_training.policies import Policy, fly_policy
    from quad_dob_training.rollout import fly

    scenario = make_scenario("dryden-helix-gusts", duration=1.0)
    evaluated = fly_policy(Policy("base", "geometric-ndob:tuned"), scenario, [4])[0]
    plain = fly(make_controller("geometric-ndob:tuned"), [scenario], seed=4)[0]
    np.testing.assert_array_equal(evaluated.position, plain.position)
    np.testing.assert_allclose(evaluated.desired_rotation, plain.desired_rotation,
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(evaluated.force_estimate, plain.force_estimate,
                               rtol=0, atol=1e-12)


def test_a_run_off_a_terminal_prints_a_line_per_evaluation(tmp_path, capsys):
    """`quad-dob train > log`: the progress bar would draw nothing until the end, so each
    evaluation prints its line (here stdout is pytest's capture, not a terminal)."""
    train(_tiny("direct", "QuadDOB/Hover-v1"), tmp_path, evaluate_every=128)
    printed = [line for line in capsys.readouterr().out.splitlines()
               if " timesteps: RMS position " in line]
    rows = (tmp_path / "evaluations.csv").read_text().splitlines()[1:]
    assert len(printed) == len(rows) >= 2
    assert printed[0].startswith("0 timesteps: RMS position ")
    assert [line.split(" timesteps")[0].replace(",", "") for line in printed] == [
        row.split(",")[0] for row in rows]


@pytest.mark.slow
def test_evaluation_rows_score_the_weights_of_their_own_timesteps_and_never_repeat(tmp_path):
    """An evaluation that falls due inside a rollout runs at the next rollout's start, where
    the weights are those of exactly that many timesteps; the last row is the final model.
    (It ran mid-rollout, so a row scored the weights of an earlier count, and the run's end
    scored the final weights again under the same count: a repeated row, other numbers.)"""
    import csv

    from quad_dob_env import make_scenario
    from quad_dob_training.evaluation.metrics import flight_metrics
    from quad_dob_training.learning.baseline_evaluation import EVAL_SEEDS
    from quad_dob_training.policies import fly_policy

    config = resolve_config("ppo", "direct", "QuadDOB/Hover-v1", "hover-calm", 768, 8, seed=3)
    config["algo_kwargs"].update(n_steps=32, batch_size=64, n_epochs=1)  # rollouts of 256
    train(config, tmp_path, evaluate_every=300, progress_bar=False)
    with open(tmp_path / "evaluations.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    assert [int(row["timesteps"]) for row in rows] == [0, 512, 768]
    final = make_policy(f"ppo:{tmp_path}")
    flights = fly_policy(final, make_scenario("hover-calm"), EVAL_SEEDS)
    scored = float(np.mean([flight_metrics(f)["rms_position_settled"] for f in flights]))
    assert float(rows[-1]["rms_position"]) == pytest.approx(scored, rel=1e-12)


def test_residual_v2_is_the_policy_trained_in_v2s_randomised_loop_and_flies_the_named_loop():
    from quad_dob_env.scenarios import make_scenario
    from quad_dob_training.policies import fly_policy

    policy = make_policy("residual:v2")
    assert policy.base_benchmark == "v2" and policy.base == "geometric-ndob:tuned"
    trained = policy.config["env_kwargs"]
    assert trained["authority_signal"] == "wind" and "loop_randomization" in trained
    assert trained["floor_fade"] == [0.3, 0.6]  # and evaluation flies it too
    assert policy.env_kwargs()["floor_fade"] == [0.3, 0.6]
    assert "loop_randomization" not in policy.env_kwargs()  # evaluation flies the named loop
    flights = fly_policy(policy, make_scenario("gusty-hover", benchmark="v2", duration=3.0),
                         [1, 2])
    assert all(flight.termination_reason in ("", "time_limit") for flight in flights)


def test_residual_v1_names_the_shipped_v1_policy_so_v1_tables_keep_reproducing():
    shipped, pinned = make_policy("residual"), make_policy("residual:v1")
    assert pinned.name == "residual:v1" and pinned.base == shipped.base
    assert pinned.fingerprint == shipped.fingerprint and pinned.base_benchmark == "v1"
    first, second = shipped.model.policy.state_dict(), pinned.model.policy.state_dict()
    assert all(np.array_equal(first[key].numpy(), second[key].numpy()) for key in first)


@pytest.mark.slow
def test_a_v2_id_trains_and_is_evaluated_during_training_in_v2s_loop(tmp_path):
    """quad-dob train takes the -v2 ids: the run's env and its evaluations against the base
    fly Benchmark v2's loop (sensing, inner loop, motors), the base at v2's gains."""
    import yaml

    from quad_dob_training.learning.baseline_evaluation import BaselineEvaluation
    from quad_dob_training.rl.run_config import HYPERPARAMS

    # a v2 entry as a user's --conf-file gives it: the v1 id's hyperparameters
    table = yaml.safe_load((HYPERPARAMS / "ppo.yml").read_text())
    conf = tmp_path / "ppo.yml"
    conf.write_text(yaml.safe_dump({"QuadDOB/HoverResidual-v2":
                                    table["QuadDOB/HoverResidual-v1"]}))
    config = resolve_config("ppo", "residual", "QuadDOB/HoverResidual-v2", None, 256, 8, 3,
                            hyperparams=conf)
    assert config["env_kwargs"]["benchmark"] == "v2"
    evaluation = BaselineEvaluation(config, tmp_path, 10**9)
    assert evaluation._scenario.loop.benchmark == "v2" and evaluation._scenario.loop.inner_rate > 0
    config["algo_kwargs"].update(n_steps=32, batch_size=64, n_epochs=1)
    run = tmp_path / "run"
    train(config, run, evaluate_every=10**9, progress_bar=False)
    policy = make_policy(f"residual:{run}")
    assert policy.base_benchmark == "v2"
    # an id that is not registered is refused with the registered ones, v3's among them
    with pytest.raises(ValueError, match=r"unknown env id 'QuadDOB/Hover-v9'.*QuadDOB/Hover-v3"):
        resolve_config("ppo", "direct", "QuadDOB/Hover-v9", None, 10, 1, 0)
    # a v3 id is trained, given hyperparameters: a file without its entry names the entries
    # it has (the shipped files have one for every id: tests/test_rl_zoo.py)
    with pytest.raises(ValueError, match=r"no entry for QuadDOB/Hover-v3.*HoverResidual-v2"):
        resolve_config("ppo", "direct", "QuadDOB/Hover-v3", None, 10, 1, 0, hyperparams=conf)
