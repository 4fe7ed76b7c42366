"""The ``quad-dob`` command line."""

from __future__ import annotations

import argparse
import sys


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


def _demo(args: argparse.Namespace) -> int:
    from training.demo import main as demo_main

    return demo_main(seed=args.seed)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="quad-dob", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    demo = commands.add_parser("demo", help="fly every scenario once and print what happened")
    demo.add_argument("--seed", type=int, default=0, help="reset seed (default 0)")
    demo.set_defaults(handler=_demo)
    listing = commands.add_parser("list", help="list env ids, scenarios and vehicles")
    listing.set_defaults(handler=_list)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return args.handler(args)


if __name__ == "__main__":
    sys.exit(main())
