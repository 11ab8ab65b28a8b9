"""``python -m paper --out DIR [--n 121]``: see :mod:`paper.cli`."""

from .cli import main

main()
