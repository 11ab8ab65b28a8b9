"""Observability: Γ and its rank, Fisher information, maps, grids, the CRLB, layouts and their
optimisers.

:mod:`.gamma` (Γ, rank, unobservable direction, observability index), :mod:`.fisher`,
:mod:`.grids` (planes and station layouts of the paper), :mod:`.maps` (a measure over a plane)
and :mod:`.design` (CRLB, error ellipses, layout criteria, spacing curves and the layout search).
"""
