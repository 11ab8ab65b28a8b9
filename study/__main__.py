"""``python -m study SCENARIO.yaml --out DIR``: :mod:`study.cli`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
