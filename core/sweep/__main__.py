"""``python -m core.sweep``: the two-parameter sweep, :mod:`core.cli.sweep` (see its notes)."""

import os
import sys

from ..cli.sweep import main

if __name__ == "__main__":
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.exit(main())
