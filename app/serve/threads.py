"""Process-wide serving settings (public configuration only; ``configure`` is called by
app/main.py). Nothing here changes a library's classes or modules."""

from __future__ import annotations

import sys

#: A map is computed on a worker thread while Panel's Python runs on others; the worker gives up
#: the GIL in every numpy/numba call and, with Python's default 5 ms switch interval, may wait
#: that long to get it back each time (the compute took 3–5× its in-process time inside the
#: server). 0.5 ms lets it resume promptly.
SWITCH_INTERVAL = 0.0005


def configure():
    """Apply the process-wide settings: Python's thread switch interval."""
    sys.setswitchinterval(SWITCH_INTERVAL)
