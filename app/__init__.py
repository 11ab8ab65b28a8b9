"""The Panel dashboard. ``panel serve app`` runs :mod:`app.main`.

The maps' kernels run on numba's OpenMP threads. GNU OpenMP's threads spin after each parallel
region by default, waiting for the next: on a server that answers many sessions on two cores,
that spin is CPU taken from the event loop and the other sessions (~3 ms of the ~24 ms of CPU of
a default update's maps, same wall time; docs/performance.md). Passive: they sleep at once. Set
before the threading layer loads (at the first parallel kernel), unless the user set it.
"""

import os

os.environ.setdefault("OMP_WAIT_POLICY", "passive")
