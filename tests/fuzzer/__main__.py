"""``python tests/fuzzer ...`` (the hand run, and each child process of ``isolation``) and
``python -m fuzzer ...`` from ``tests/``: the command line, ``cli.main``.

Run as a directory, Python puts this folder first on ``sys.path`` and runs this file
outside any package; ``tests/`` takes the folder's place there, so the package imports as
``fuzzer`` (and none of its modules as a top-level module of its own).
"""

import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent
if sys.path and Path(sys.path[0] or ".").resolve() == _HERE:
    sys.path[0] = str(_HERE.parent)

from fuzzer.cli import main  # noqa: E402 (once tests/ is on sys.path)

if __name__ == "__main__":
    sys.exit(main())
