"""The ``quad-dob`` command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _list(_: argparse.Namespace) -> int:
    import quad_dob_env
    from quad_dob_env.scenarios import make_scenario

    print("Environment ids:")
    for env_id, scenario in quad_dob_env.ENV_IDS.items():
        print(f"  {env_id:<20} default scenario {scenario}")
    print("Scenarios:")
    for name in quad_dob_env.list_scenarios():
        print(f"  {name:<22} {make_scenario(name).description}")
    print("Vehicles:", ", ".join(quad_dob_env.VEHICLES))
    return 0


def _paper(args: argparse.Namespace) -> int:
    from training.paper import main as paper_main

    return paper_main(_names(args.scenarios), _names(args.controllers), args.torque_reading,
                      args.dt, args.substeps, args.out, args.json, not args.no_figures)


def _names(text: str) -> list[str]:
    return [name.strip() for name in text.split(",") if name.strip()]


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="quad-dob", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    from training.paper import PAPER_CONTROLLERS, PAPER_SCENARIOS

    paper = commands.add_parser(
        "paper", help="reproduce the paper: every controller in its scenarios, table + figures")
    paper.add_argument("--scenarios", default=",".join(PAPER_SCENARIOS),
                       help="comma-separated scenario names (default: %(default)s)")
    paper.add_argument("--controllers", default=",".join(PAPER_CONTROLLERS),
                       help="comma-separated controller names (default: %(default)s)")
    paper.add_argument("--torque-reading", default="0.6*dx", choices=["0.6*dx", "dx/0.6"],
                       help="how to read the paper's 'd_x = 0.6 d_Ω' (default: %(default)s)")
    paper.add_argument("--dt", type=_positive_float, default=None,
                       help="control period [s] (default: the scenario's, 0.01)")
    paper.add_argument("--substeps", type=_positive_int, default=None,
                       help="physics substeps per control step (default: 1)")
    paper.add_argument("--out", type=Path, default=Path("results"),
                       help="output folder (default: %(default)s)")
    paper.add_argument("--json", action="store_true", help="print the table as JSON rows")
    paper.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    paper.set_defaults(handler=_paper)
    listing = commands.add_parser("list", help="list env ids, scenarios and vehicles")
    listing.set_defaults(handler=_list)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.handler(args)
    except ValueError as error:  # bad names or values: say what and what is allowed
        parser.exit(2, f"quad-dob: error: {error}\n")


if __name__ == "__main__":
    sys.exit(main())
