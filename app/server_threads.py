"""Process-wide settings for serving many sessions from threads (imported by app/main.py)."""

from __future__ import annotations

import functools
import sys
import threading

import panel as pn

#: A map is computed on a worker thread while Panel's Python runs on others; the worker gives up
#: the GIL in every numpy/numba call and, with Python's default 5 ms switch interval, may wait
#: that long to get it back each time (the compute took 3–5× its in-process time inside the
#: server). 0.5 ms lets it resume promptly.
SWITCH_INTERVAL = 0.0005

_BUSY_LOCK = threading.RLock()


def serialise_busy_counter():
    """Panel counts busy events in its process-wide state from every worker thread
    (``--num-threads``), each time lifting the read-only flags of *all* its parameters and
    restoring them afterwards; two threads interleaving there restore "read-only" under each
    other, and the event being processed fails with "Read-only parameter 'busy' cannot be
    modified" (seen in the load test: an update never answered). One lock around the three
    methods that do it."""
    cls = type(pn.state)
    for name in ("_add_busy_event", "_remove_busy_event", "_cleanup_busy_counter"):
        method = getattr(cls, name)
        if getattr(method, "_serialised", False):
            continue

        @functools.wraps(method)
        def locked(self, *args, _method=method, **kwargs):
            with _BUSY_LOCK:
                return _method(self, *args, **kwargs)

        locked._serialised = True
        setattr(cls, name, locked)


def configure():
    sys.setswitchinterval(SWITCH_INTERVAL)
    serialise_busy_counter()
