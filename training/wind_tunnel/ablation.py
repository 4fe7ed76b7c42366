"""What the wind-tunnel ablation scripts (``benchmarks/wind_tunnel_ablation_v3.py``,
``_v4.py``) share: their command line and the choice of variants from it."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from pathlib import Path
from typing import Any


def ablation_arguments(description: str, seeds: str) -> argparse.Namespace:
    """The scripts' options: ``--seeds`` (``seeds`` by default), ``--variants``, ``--list``
    and ``--json``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--seeds", default=seeds)
    parser.add_argument("--variants", default="",
                        help="comma-separated labels (default: all); see --list")
    parser.add_argument("--list", action="store_true", help="print the labels and stop")
    parser.add_argument("--json", type=Path, help="also write the results here")
    return parser.parse_args()


def chosen_variants(arguments: argparse.Namespace, table: Mapping[str, Any]) -> list[str]:
    """The labels ``--variants`` names (all of ``table``'s by default), in its order;
    ``--list`` prints every label and chooses none. An unknown label stops the script,
    naming the valid ones."""
    if arguments.list:
        print("\n".join(table))
        return []
    wanted = [label.strip() for label in arguments.variants.split(",") if label.strip()]
    for label in wanted:
        if label not in table:
            raise SystemExit(f"unknown variant {label!r}; the variants: {', '.join(table)}")
    return wanted or list(table)
