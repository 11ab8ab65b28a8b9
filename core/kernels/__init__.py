"""The compiled kernels (numba), in one leaf.

Every ``@njit`` of :mod:`core` lives here and imports only math, numpy, numba and the other
modules of this package, never the validated numpy fronts that call it (as empymod's
``kernel.py``): :mod:`.electric` (the dipole's field and Jacobian, the image sums),
:mod:`.sea` (the layered sea's image series), :mod:`.gamma` (Γ per point and per map lane and
its measures), :mod:`.magnetic` (the magnetic dipole, its tensor and their Jacobians),
:mod:`.filters` (the EKF steps), :mod:`.pcrlb` (the PCRLB recursion) and :mod:`.loss` (the
CRLB with one station lost). They assume validated
float64 input. :mod:`core.kernel_cache` keys their on-disk cache by these files' sources.
"""
