"""``python -m core.design``: survey layout design from the command line, :mod:`core.cli.design`
(see its notes). The functions are core's own (:func:`core.optimise_layout`,
:func:`core.station_loss`, :func:`core.station_count_curve`); this package is only the entry."""
