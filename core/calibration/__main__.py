"""``python -m core.calibration DATA.csv --be BX,BY,BZ``: see :mod:`core.calibration.cli`."""

import sys

from .cli import main

sys.exit(main())
