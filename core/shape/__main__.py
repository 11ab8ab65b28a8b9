"""``python -m core.shape``: see :mod:`core.cli.shape`."""

from ..cli.shape import main

main()
