"""``python -m core.calibration DATA.csv --be BX,BY,BZ``: see :mod:`core.cli.calibration`."""

import sys

from ..cli.calibration import main

sys.exit(main())
