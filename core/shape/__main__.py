"""``python -m core.shape``: see :mod:`core.shape.cli`."""

from .cli import main

main()
