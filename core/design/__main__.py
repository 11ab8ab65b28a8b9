"""``python -m core.design``: see :mod:`core.cli.design`."""

import sys

from ..cli.design import main

if __name__ == "__main__":
    sys.exit(main())
