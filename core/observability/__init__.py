"""Observability: Γ and its rank, Fisher information, maps, grids, the CRLB, layouts and their
optimisers.

:mod:`.gamma` (Γ, rank, unobservable direction, observability index), :mod:`.fisher`,
:mod:`.grids` (planes and station layouts of the paper), :mod:`.maps` (a measure over a plane),
:mod:`.crlb` (the CRLB covariance, error ellipses and their maps), :mod:`.layouts` (N-station
layouts) and :mod:`.design` (layout criteria, spacing curves and the layout search; it re-exports
the public names of :mod:`.crlb` and :mod:`.layouts`).
"""
