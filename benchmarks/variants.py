"""What the docs' table scripts share: the evaluation rows of one folder per variant."""

from __future__ import annotations

import argparse
import csv
from pathlib import Path


def variant_rows(description: str, variants: dict[str, str]) -> dict[str, list[dict]]:
    """Parse the command line's results folder and read ``<folder>/<variant>/evaluation.csv``
    for each variant that was run, in ``variants``' order."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("folder", type=Path)
    folder = parser.parse_args().folder
    return {name: list(csv.DictReader(open(folder / name / "evaluation.csv")))
            for name in variants if (folder / name / "evaluation.csv").exists()}
