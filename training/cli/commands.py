"""The ``quad-dob`` command line.

Every value and file the command line is given is checked before any work starts (an output
folder that cannot be written, a budget beyond reason), and every failure it can name comes
back as ``quad-dob: error: ...`` with exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from quad_dob_env.benchmark import BENCHMARKS, TOOLS_BENCHMARK
from quad_dob_training.cli.checks import (
    MAX_TIMESTEPS,
    comma_list,
    delay_grid,
    key_values,
    number_in,
    positive_float,
    positive_int,
    seed_number,
    tuning_seeds,
    writable_file,
    writable_folder,
)
from quad_dob_training.cli.listing import ALGORITHMS, print_hyperparams
from quad_dob_training.cli.listing import main as list_main
from quad_dob_training.evaluation.margins import DELAY_GRID, DELAY_PATHS
from quad_dob_training.real_flights import CRAZYSWARM2_LOGS
from quad_dob_training.wind_tunnel.published import COUNTERPART_SETS

MAX_VIDEO_WIDTH = 4096  # a panel's pixels
MAX_FPS = 1000.0


def _paper(args: argparse.Namespace) -> int:
    from quad_dob_training.paper import main as paper_main

    writable_folder(args.out, "--out")
    return paper_main(comma_list(args.scenarios), comma_list(args.controllers),
                      args.torque_reading, args.dt, args.substeps, args.out, args.json,
                      not args.no_figures)


def _train(args: argparse.Namespace) -> int:
    from quad_dob_env.envs.limits import check_vehicle_memory

    if args.conf_file is not None and not args.conf_file.is_file():
        raise ValueError(f"--conf-file {str(args.conf_file)!r} is not a file: give a "
                         "hyperparameter YAML in rl-zoo3's schema (see training/hyperparams/)")
    if args.n_envs is not None:
        check_vehicle_memory(args.n_envs, "--n-envs")
    if args.out is not None:
        writable_folder(args.out, "--out")
    elif args.resume is not None and args.resume.suffix != ".zip" and args.resume.exists():
        from quad_dob_training.rl.run_folder import run_folder

        writable_folder(args.resume if args.resume.is_dir() else run_folder(args.resume),
                         "--resume's run folder")
    elif args.resume is None or args.resume.suffix == ".zip":
        writable_folder(Path(f"runs/{args.algo}"), "the default --out")
    from quad_dob_training.learning.train import main as train_main  # torch: seconds to import

    return train_main(args.algo, args.mode, args.env, args.scenario, args.timesteps,
                      args.n_envs, args.seed, args.out, args.resume, args.base,
                      args.checkpoint_every, args.evaluate_every, not args.no_progress,
                      args.conf_file, trust_pickle=args.trust_pickle)


def _evaluate(args: argparse.Namespace) -> int:
    from quad_dob_training.evaluation.evaluate import main as evaluate_main

    if not args.json:
        writable_folder(args.out, "--out")
    elif args.merge:
        raise ValueError("--merge writes leaderboard-merged.md into --out, and --json writes "
                         "nothing: drop one (quad-dob leaderboard merges files alone)")
    options = key_values(args.scenario_option or [], "--scenario-option")
    if args.benchmark is not None and options.get("benchmark", args.benchmark) != args.benchmark:
        raise ValueError(f"--benchmark {args.benchmark} and --scenario-option "
                         f"benchmark={options['benchmark']} disagree: give one")
    if args.env is not None:  # the id supplies the benchmark; one given must be the id's
        from quad_dob_training.rl.sb3_adapter import id_benchmark

        flies, given = id_benchmark(args.env), options.get("benchmark", args.benchmark)
        if given is not None and given != flies:
            # name the option the value came from (the two agree where both are given)
            said, option = ((f"--benchmark {given}", "--benchmark")
                            if args.benchmark is not None else
                            (f"--scenario-option benchmark={given}", "that option"))
            raise ValueError(f"{said} disagrees with --env {args.env}, whose benchmark is "
                             f"{flies}: leave {option} out (the id supplies it) or give the "
                             f"{given} id the model was trained on")
        options.setdefault("benchmark", flies)
    options.setdefault("benchmark", args.benchmark or TOOLS_BENCHMARK)
    return evaluate_main(comma_list(args.policies), comma_list(args.scenarios), args.seeds,
                         args.out, args.json, args.baseline, args.suite,
                         trust_pickle=args.trust_pickle,
                         scenario_options=options, delay_grid=args.delay_margins,
                         delay_path=args.delay_on, env_id=args.env,
                         merge=args.merge, command=["quad-dob", *args.argv])


def _leaderboard(args: argparse.Namespace) -> int:
    from quad_dob_training.evaluation.results import (
        console_leaderboard,
        merged_leaderboard,
        read_document,
        source_labels,
    )

    if args.out is not None:
        writable_file(args.out, "--out")
    documents = [read_document(path) for path in args.files]
    sources = list(zip(source_labels(args.files), documents, strict=True))
    print(console_leaderboard(sources))
    if args.out is not None:
        args.out.write_text(merged_leaderboard(sources))
    return 0


def _tune(args: argparse.Namespace) -> int:
    from quad_dob_env.params import get_vehicle
    from quad_dob_training.tuning.tune import main as tune_main

    get_vehicle(args.vehicle)  # an unknown name fails here, naming the presets
    writable_folder(args.out, "--out")
    return tune_main(None if args.controllers is None else comma_list(args.controllers),
                     args.out, args.benchmark or TOOLS_BENCHMARK, args.vehicle, seeds=args.seeds,
                     passes=args.passes)


def _check_controller(args: argparse.Namespace) -> int:
    from quad_dob_composition.checks import check_controller
    from quad_dob_env.params import get_vehicle

    get_vehicle(args.vehicle)
    problems = check_controller(args.controller, args.vehicle,
                                args.benchmark or TOOLS_BENCHMARK)
    for problem in problems:
        print(f"- {problem}")
    print(f"{args.controller}: " + (f"{len(problems)} problem(s)" if problems else
                                    "passes every check (interface, batch, reset, calm hover)"))
    return 1 if problems else 0


def _replay(args: argparse.Namespace) -> int:
    from quad_dob_training.cli.replay import main as replay_main

    writable_file(args.out, "--out")
    return replay_main(comma_list(args.policy), args.scenario, args.seed, args.out, args.fps,
                       args.width, trust_pickle=args.trust_pickle, benchmark=args.benchmark)


def _sweep(args: argparse.Namespace) -> int:
    from quad_dob_training.learning.sweep import run_sweep

    if not args.config.is_file():
        raise ValueError(f"sweep config {str(args.config)!r} is not a file: give a sweep's "
                         "YAML (see training/sweeps/)")
    if args.out is not None:
        writable_folder(args.out, "--out")
    run_sweep(args.config, args.out, args.ray_address, args.workers)
    return 0


def _wind_tunnel(args: argparse.Namespace) -> int:
    from quad_dob_training.wind_tunnel.tool import main as wind_tunnel_main

    writable_folder(args.out, "--out")
    return wind_tunnel_main(args.benchmark, args.seeds, args.neural_fly, args.out,
                            args.duration, args.counterparts)


def _real_flights(args: argparse.Namespace) -> int:
    from quad_dob_training.evaluation.evaluate import parse_seeds
    from quad_dob_training.real_flights.crazyswarm2 import main as crazyswarm2_main

    writable_folder(args.out, "--out")
    for folder, flag in ((args.logs, "--logs"), (args.trajectories, "--trajectories")):
        if not folder.is_dir():
            raise ValueError(f"{flag} {str(folder)!r} is not a folder")
    # a log's flight: 10 s of lead-in and up to 20 s of log at 500 Hz
    return crazyswarm2_main(args.logs, args.trajectories, args.log or list(CRAZYSWARM2_LOGS),
                            parse_seeds(args.seeds, 15000), args.out)


def _benchmark_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--benchmark", default=None, choices=list(BENCHMARKS),
                        help="the loop every scenario is flown in: v4, v3's loop with five "
                        "mechanisms corrected against Neural-Fly's logs (docs/benchmark-v4.md; "
                        "its own gains), v3, the real vehicle's "
                        "lag and thrust path on v2's loop (docs/benchmark-v3.md; the gains "
                        "tuned for it), v2, the vehicle's own loop (mocap sensing, inner "
                        "loop, motors, thrust uncertainty, rotor aerodynamics), to reproduce "
                        "v2's tables, or v1, the ideal loop, to reproduce v1's (default: "
                        f"{TOOLS_BENCHMARK})")


def _trust_pickle_option(command: argparse.ArgumentParser) -> None:
    command.add_argument("--trust-pickle", action="store_true",
                         help="load model files whose pickled entries run code when loaded "
                         "(only files you made or trust); without it such a file is refused")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="quad-dob", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    from quad_dob_training.paper import PAPER_CONTROLLERS, PAPER_SCENARIOS

    paper = commands.add_parser(
        "paper", help="reproduce the paper: every controller in its scenarios, table + figures")
    paper.add_argument("--scenarios", default=",".join(PAPER_SCENARIOS),
                       help="comma-separated scenario names (default: %(default)s)")
    paper.add_argument("--controllers", default=",".join(PAPER_CONTROLLERS),
                       help="comma-separated controller names (default: %(default)s)")
    paper.add_argument("--torque-reading", default="0.6*dx", choices=["0.6*dx", "dx/0.6"],
                       help="how to read the paper's 'd_x = 0.6 d_Ω' (default: %(default)s)")
    paper.add_argument("--dt", type=positive_float, default=None,
                       help="control period [s] (default: the scenario's, 0.01)")
    paper.add_argument("--substeps", type=positive_int, default=None,
                       help="physics substeps per control step (default: 1)")
    paper.add_argument("--out", type=Path, default=Path("results"),
                       help="output folder (default: %(default)s)")
    paper.add_argument("--json", action="store_true", help="print the table as JSON rows")
    paper.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    paper.set_defaults(handler=_paper)
    train = commands.add_parser(
        "train", help="train PPO, SAC or TD3 (stable-baselines3) on the vector env, residual or "
        "direct; resumable")
    train.add_argument("--algo", default="ppo", choices=ALGORITHMS,
                       help="the stable-baselines3 algorithm (default: %(default)s)")
    train.add_argument("--mode", default="residual", help="residual or direct "
                       "(default: %(default)s)")
    train.add_argument("--env", default="QuadDOB/TrackResidual-v1",
                       help="env id; its hyperparameters come from the --conf-file "
                       "(default: %(default)s)")
    train.add_argument("--conf-file", type=Path, default=None,
                       help="hyperparameters per env id in rl-zoo3's schema (default: "
                       "training/hyperparams/ALGO.yml)")
    train.add_argument("--scenario", default=None, help="scenario (default: the yml's)")
    train.add_argument("--base", default=None,
                       help="base controller of a residual (default: the yml's)")
    train.add_argument("--timesteps", type=positive_int, default=None,
                       help=f"at most {MAX_TIMESTEPS:.0e} (default: the yml's)")
    train.add_argument("--n-envs", type=positive_int, default=None,
                       help="vehicles trained in parallel (default: the yml's n_envs)")
    train.add_argument("--seed", type=seed_number, default=0,
                       help="seeds the envs and the algorithm: policy initialisation, sampling "
                       "(default: %(default)s)")
    train.add_argument("--out", type=Path, default=None,
                       help="run folder (default: runs/ALGO, or the resumed run's own)")
    train.add_argument("--resume", type=Path, default=None,
                       help="a run folder (its newest checkpoint) or a checkpoint's .state: "
                       "finishes that run as if it had never stopped; or a model .zip: "
                       "trains --timesteps more from its weights (default: a fresh run)")
    train.add_argument("--checkpoint-every", type=positive_int, default=None,
                       help="timesteps between checkpoints, of which the run keeps its "
                       "newest two (default: 100000, or the resumed run's own)")
    train.add_argument("--evaluate-every", type=positive_int, default=None,
                       help="timesteps between evaluations against the base, each run at "
                       "the first rollout's start past it (default: 100000, or the resumed "
                       "run's own)")
    train.add_argument("--no-progress", action="store_true",
                       help="no progress bar on a terminal: a line per rollout instead, as in "
                       "a log")
    _trust_pickle_option(train)
    train.set_defaults(handler=_train)
    evaluate = commands.add_parser(
        "evaluate", help="score policies on scenarios over seeds: table, CSV, JSON, bar plot")
    # the demo's comparison: the strongest classical baselines, the v1 policy (the "before")
    # and the policies trained in v3's and v4's loops
    evaluate.add_argument("--policies", default="geometric-ndob:tuned,indi,pid,"
                          "residual:v1,residual:v3,residual:v4",
                          help="comma-separated: controller names, "
                          "py:package.module:Name (your own), ppo:PATH, sac:PATH, td3:PATH "
                          "(a model zip or its run folder: quad-dob train's, or one saved by "
                          "stable-baselines3 or rl-zoo3, with --env), residual (the newest "
                          "shipped policy trained in the benchmark flown: residual:v1 in v1, "
                          "residual:v2 in v2, residual:v3 in v3, residual:v4 in v4; rows name "
                          "the one flown), residual:v1 (the policy shipped for v1's ideal "
                          "loop), residual:v2 (the one trained in v2's loop), residual:v3 (in "
                          "v3's), residual:v4 (in v4's), "
                          "residual:PATH, oracle:NAME (NAME, a geometric NDOB base, fed the "
                          "simulator's true disturbance: the loop's floor where it is one) "
                          "(default: %(default)s)")
    evaluate.add_argument("--env", default=None, metavar="ID",
                          help="the env id every model zip without a training config beside "
                          "it (saved by stable-baselines3's model.save or by rl-zoo3) was "
                          "trained on: it supplies the base controller, the residual options "
                          "and the benchmark (a --benchmark must agree); --scenarios chooses "
                          "what is flown. An rl-zoo3 run's args.yml names its own id, used "
                          "when --env is left out. Left out, a zip with neither a training "
                          "config nor an rl-zoo3 run's files beside it is refused (default: "
                          "not given)")
    evaluate.add_argument("--scenarios", default="dryden-helix-gusts",
                          help="comma-separated scenario names (default: %(default)s)")
    evaluate.add_argument("--seeds", default="9001-9020",
                          help="a count N (seeds 0..N-1) or a range A-B (default: %(default)s)")
    evaluate.add_argument("--out", type=Path, default=Path("results/evaluation"),
                          help="folder for evaluation.md, .json, .csv, .png and report.html "
                          "(plotly.min.js beside it) (default: %(default)s)")
    evaluate.add_argument("--baseline", default=None,
                          help="controller every policy is compared with, paired over the "
                          "seeds with 95 %% bootstrap intervals; '' for none (default: the "
                          "recommended base, geometric-ndob:tuned)")
    evaluate.add_argument("--suite", action="store_true",
                          help="every scenario family of the benchmark (wind, calm, forces, "
                          "references; v2 adds the wind tunnel) instead of --scenarios, and "
                          "leaderboard.md: means with 95 %% intervals and paired differences "
                          "to the baseline")
    _benchmark_option(evaluate)
    evaluate.add_argument("--scenario-option", action="append", metavar="KEY=VALUE",
                          help="an option for every scenario flown (make_scenario's keywords: "
                          "dt=0.005, duration=20, wind_scale=1.5, motor_lag=true, ...); "
                          "repeatable (default: none, each scenario as it is named)")
    evaluate.add_argument("--delay-margins", nargs="?", type=delay_grid, default=None,
                          const=",".join(f"{v:g}" for v in DELAY_GRID), metavar="GRID",
                          help="also each policy's delay margin: the largest extra latency of "
                          "GRID (comma-separated seconds, default %(const)s) that keeps every "
                          "flight")
    evaluate.add_argument("--delay-on", choices=tuple(DELAY_PATHS), default=None,
                          help="where --delay-margins adds its latency: 'readings' (every "
                          "reading, pose, IMU and rotors: v1's and v2's margin) or 'pose' (the "
                          "pose fix alone, unknown to the estimator: v3's margin) (default: "
                          "the benchmark's margin's place)")
    evaluate.add_argument("--json", action="store_true", help="print the rows as JSON")
    evaluate.add_argument("--merge", type=Path, nargs="+", default=[], metavar="JSON",
                          help="others' evaluation.json files, merged with this run's into "
                          "leaderboard-merged.md, one table per benchmark version (default: "
                          "none)")
    _trust_pickle_option(evaluate)
    evaluate.set_defaults(handler=_evaluate)
    board = commands.add_parser(
        "leaderboard", help="merge evaluation.json files from different users and machines "
        "into one leaderboard, one table per benchmark version")
    board.add_argument("files", type=Path, nargs="+", help="evaluation.json files")
    board.add_argument("--out", type=Path, default=None,
                       help="also write the leaderboard to this Markdown file (default: only "
                       "print it)")
    board.set_defaults(handler=_leaderboard)
    tune = commands.add_parser(
        "tune", help="choose the baselines' gains and the observer rates on tuning seeds "
        "(100-109), by the procedure in training/tuning/tune.py")
    tune.add_argument("--controllers", default=None,
                      help="comma-separated: pid, smc, geometric-integral, indi, l1, "
                      "l1-matched, indi-outer, nf-constant, nf-baseline (Neural-Fly's laws, "
                      "their K and Λ), geometric-ndob:tuned (the geometric gains; in v2 with "
                      "the observer's rates), in v1 geometric-ndob (the observer's rates "
                      "alone), or a user controller py:package.module:Name that declares "
                      "tunable_gains "
                      "(default: v2's six, v1's geometric-ndob,pid,smc)")
    _benchmark_option(tune)
    tune.add_argument("--vehicle", default="paper",
                      help="the vehicle the tuning scenarios are flown with (v2; v1 tunes "
                      "on the paper vehicle) (default: %(default)s)")
    tune.add_argument("--out", type=Path, default=Path("results/tuning"),
                      help="folder for tuning.json, every trial of the search "
                      "(default: %(default)s)")
    tune.add_argument("--seeds", type=tuning_seeds, default=None,
                      help="tuning seeds, a count or a range A-B (default: 100-109, which "
                      "every shipped set was tuned on; evaluation's 9001-9020 are refused)")
    tune.add_argument("--passes", type=number_in(int, 1, 10, "a whole number"), default=None,
                      help="passes of the descent over the gains, 1 to 10 (default: 2, "
                      "and in v2 up to 2 more while the best loses margin flights)")
    tune.set_defaults(handler=_tune)
    check = commands.add_parser(
        "check-controller", help="check a controller (py:package.module:Name, or any name) "
        "against the Controller interface and fly it in a calm hover; exit 1 on a problem")
    check.add_argument("controller", help="the controller's name, e.g. "
                       "py:example_pd.controller:HoverPD")
    _benchmark_option(check)
    check.add_argument("--vehicle", default="paper",
                       help="the vehicle it is built for and flown on (default: %(default)s)")
    check.set_defaults(handler=_check_controller)
    replay = commands.add_parser(
        "replay", help="render one episode of one or more policies (side by side) to a video")
    replay.add_argument("--policy", default="geometric,geometric-ndob:tuned",
                        help="comma-separated policies, as for evaluate (default: %(default)s)")
    replay.add_argument("--scenario", default="paper-II",
                        help="the scenario flown (default: %(default)s)")
    replay.add_argument("--seed", type=seed_number, default=0,
                        help="the episode's seed (default: %(default)s)")
    # v1 unless told, as the library: the default scenario is the paper's (moments applied
    # directly), which only v1's ideal loop flies as the paper did
    replay.add_argument("--benchmark", default="v1", choices=list(BENCHMARKS),
                        help="the loop the scenario is flown in; a model flies it on its "
                        "base's training gains, and bare residual is this benchmark's "
                        "shipped policy (default: %(default)s)")
    replay.add_argument("--out", type=Path, default=Path("results/flight.gif"),
                        help="a .gif or .mp4 path (default: %(default)s)")
    replay.add_argument("--fps", type=number_in(float, 0, MAX_FPS, "a number", True), default=20.0,
                        help="frames per second of flight (default: %(default)s)")
    replay.add_argument("--width", type=number_in(int, 16, MAX_VIDEO_WIDTH, "a whole number"),
                        default=400, help="width of each policy's panel in pixels, 16 to "
                        f"{MAX_VIDEO_WIDTH} (default: %(default)s)")
    _trust_pickle_option(replay)
    replay.set_defaults(handler=_replay)
    sweep = commands.add_parser(
        "sweep", help="a grid or random sweep of evaluations or trainings, resumable, "
        "locally or on Ray")
    sweep.add_argument("config", type=Path, help="the sweep's YAML (see training/sweeps/)")
    sweep.add_argument("--out", type=Path, default=None,
                       help="output folder (default: results/sweeps/NAME)")
    sweep.add_argument("--ray-address", default=None,
                       help="run the tasks on Ray: auto, HOST:PORT, or local (a Ray instance "
                       "on this machine); default: a process pool, no Ray needed")
    sweep.add_argument("--workers", type=positive_int, default=None,
                       help="local processes (default: every core); with --ray-address "
                       "local, Ray's CPUs")
    sweep.set_defaults(handler=_sweep)
    tunnel = commands.add_parser(
        "wind-tunnel", help="fly the counterparts of Neural-Fly's controllers on the "
        "wind-tunnel figure-8s and score them, and optionally Neural-Fly's own logs, by the "
        "same code over the same whole laps")
    tunnel.add_argument("--benchmark", default=None, choices=list(BENCHMARKS),
                        help="the loop the figure-8s are flown in (default: the newest, "
                        f"{TOOLS_BENCHMARK})")
    tunnel.add_argument("--seeds", default="9001-9020",
                        help="a count N (seeds 0..N-1) or a range A-B (default: %(default)s)")
    tunnel.add_argument("--neural-fly", type=Path, default=None, metavar="DIR",
                        help="also read Neural-Fly's custom_figure8_<METHOD>_<COND>.csv from "
                        "DIR (your copy of their data/experiment; their terms: personal and "
                        "educational use) and score them beside the simulation, which then "
                        "flies their span (default: none)")
    tunnel.add_argument("--duration", type=positive_float, default=None,
                        help="seconds each simulated flight lasts, 12.57 or more (default: "
                        "the logs' span with --neural-fly, else the scenario's 30)")
    tunnel.add_argument("--out", type=Path, default=Path("results/wind-tunnel"),
                        help="folder for wind_tunnel.md (every table in full), "
                        "wind_tunnel.json and the PNG figures (default: %(default)s)")
    tunnel.add_argument("--counterparts", default=None, choices=list(COUNTERPART_SETS),
                        help="the controllers flown for Neural-Fly's: stand-ins (v1-v3's: "
                        "geometric-ndob:tuned, geometric-integral, indi, l1) or neural-fly "
                        "(v4's, the laws they flew: nf-constant, nf-baseline, indi-outer, "
                        "l1-matched) (default: the benchmark's)")
    tunnel.set_defaults(handler=_wind_tunnel)
    real = commands.add_parser(
        "real-flights", help="fly the simulator's counterpart of each flight of a real "
        "dataset on your copy and score both sides by the same code over the same samples "
        "(Neural-Fly's tunnel: wind-tunnel --neural-fly)")
    real.add_argument("dataset", choices=["crazyswarm2"],
                      help="crazyswarm2: the Crazyflie's logs of IMRCLab/crazyswarm2-tools")
    real.add_argument("--logs", type=Path, required=True, metavar="DIR",
                      help="your copy of IMRCLab/crazyswarm2-tools (its logs/ and info/)")
    real.add_argument("--trajectories", type=Path, required=True, metavar="DIR",
                      help="your copy of Crazyswarm2's tune-lee trajectory files "
                      "(crazyflie_examples/crazyflie_examples/data)")
    real.add_argument("--log", type=positive_int, action="append", default=None,
                      metavar="N", help="a log to compare, repeatable (default: "
                      f"{' '.join(str(n) for n in CRAZYSWARM2_LOGS)})")
    real.add_argument("--seeds", default="9001-9005",
                      help="a count N (seeds 0..N-1) or a range A-B: the sensors' noise "
                      "(default: %(default)s)")
    real.add_argument("--out", type=Path, default=Path("results/real-flights"),
                      help="folder for crazyswarm2.json (default: %(default)s)")
    real.set_defaults(handler=_real_flights)
    listing = commands.add_parser(
        "list", help="list env ids, scenarios with their feasibility margins, wind presets, "
        "controllers, policies and vehicles")
    listing.set_defaults(handler=lambda _: list_main())
    hyperparams = commands.add_parser(
        "hyperparams", help="print the path of the installed hyperparameter file of ALGO, "
        "for rl-zoo3's --conf-file from any directory")
    hyperparams.add_argument("algo", choices=ALGORITHMS, help="the algorithm's file")
    hyperparams.set_defaults(handler=lambda args: print_hyperparams(args.algo))
    return parser


def _seeds_given_whole(argv: list[str]) -> list[str]:
    """``--seeds -5-3`` as ``--seeds=-5-3``: argparse takes a value that starts with a dash
    and is not a plain negative number for an option, and answers "expected one argument";
    joined, the value reaches ``parse_seeds``, which says what seeds may be."""
    joined: list[str] = []
    rest = iter(argv)
    for word in rest:
        if word == "--seeds":
            value = next(rest, None)
            if value is not None and value[:1] == "-" and value[1:2].isdigit():
                joined.append(f"--seeds={value}")
                continue
            joined.append(word)
            if value is not None:
                joined.append(value)
            continue
        joined.append(word)
    return joined


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(_seeds_given_whole(argv))
    args.argv = argv  # what evaluation.json records as its command
    try:
        return args.handler(args)
    except BrokenPipeError:
        # the reader went away (`quad-dob list | head`): stop quietly, as Python's docs
        # advise (signal module, "Note on SIGPIPE"): point stdout at devnull so the flush
        # at exit cannot raise again, and exit 1
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except ValueError as error:  # bad names or values: say what and what is allowed
        parser.exit(2, f"quad-dob: error: {error}\n")
    except OSError as error:  # a file that could not be read or written mid-run
        where = f" {error.filename!r}" if error.filename else ""
        parser.exit(2, f"quad-dob: error: {error.strerror or error}{where}\n")


if __name__ == "__main__":
    sys.exit(main())
