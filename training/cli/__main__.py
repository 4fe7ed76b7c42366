"""``python -m quad_dob_training.cli``: the same as ``quad-dob``."""

import sys

from quad_dob_training.cli.commands import main

sys.exit(main())
