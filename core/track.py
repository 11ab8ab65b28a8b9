"""``python -m core.track``: Monte-Carlo tracking, :mod:`core.cli.track` (see its notes)."""

import sys

from .cli.track import main

if __name__ == "__main__":
    sys.exit(main())
