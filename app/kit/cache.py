"""The tabs' shared kit for pure computations: one cache of results for the whole process, and
the lock that runs numba's kernels one at a time.

A tab computes a pure function of the values it reads (a hashable snapshot of them,
:class:`app.state.snapshot.Snapshot`) through :data:`SHARED`: every session of the process showing the
same values gets the same result, computed once. Off the event loop: :mod:`app.kit.offloop`.
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict

import numpy as np

#: Numba's fallback threading layer (workqueue) must not be entered from two threads at once,
#: and one map already keeps both cores busy: kernels run one at a time. A map takes tens of ms,
#: so no session waits longer than one map for another (issue: server never blocks a session).
KERNEL_LOCK = threading.Lock()


def _arrays(value, seen=None):
    """The numpy arrays inside a result (dataclasses, tuples, lists, dicts), each once."""
    seen = set() if seen is None else seen
    if id(value) in seen:
        return
    seen.add(id(value))
    if isinstance(value, np.ndarray):
        yield value
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        for f in dataclasses.fields(value):
            yield from _arrays(getattr(value, f.name), seen)
    elif isinstance(value, (tuple, list)):
        for v in value:
            yield from _arrays(v, seen)
    elif isinstance(value, dict):
        for v in value.values():
            yield from _arrays(v, seen)


class PanelCache:
    """Recent results of the tabs' pure computations (:func:`app.tabs.maps.compute.compute`, the Layout design
    tab's :mod:`app.tabs.design.compute`, …), keyed by (function, :class:`app.state.snapshot.Snapshot`) and shared by every
    session of the process (:data:`SHARED`): the default view and the presets are computed once
    per process, not once per visitor (issue 29). Bounded by ``size`` entries and ``max_bytes``
    of arrays, least recently used out first. A key being computed is computed once: a second
    session asking for it waits for the first's result. A cached result's arrays are made
    read-only, so that no view can change what another session sees."""

    def __init__(self, size=16, max_bytes=48 * 2**20):
        self.size, self.max_bytes = size, max_bytes
        self._store = OrderedDict()  # key -> (result, bytes)
        self._pending = {}  # key -> threading.Event, set when its computation ends
        self._bytes = 0
        self._lock = threading.Lock()

    def get(self, snapshot, fn):
        """``fn(snapshot)``, from the cache when it was asked before. ``snapshot``: hashable, the
        values ``fn`` reads (:class:`app.state.snapshot.Snapshot`); ``fn``: a pure function of them."""
        key = (fn.__module__, fn.__qualname__, snapshot)
        while True:
            with self._lock:
                if key in self._store:
                    self._store.move_to_end(key)
                    return self._store[key][0]
                pending = self._pending.get(key)
                if pending is None:
                    self._pending[key] = threading.Event()
                    break
            pending.wait()  # another session computes it; if that failed, try again ourselves
        try:
            result = fn(snapshot)
        except BaseException:
            with self._lock:
                self._pending.pop(key).set()
            raise
        arrays = list(_arrays(result))
        for arr in arrays:
            arr.flags.writeable = False
        nbytes = sum(arr.nbytes for arr in arrays)
        with self._lock:
            self._pending.pop(key).set()
            if nbytes <= self.max_bytes:
                self._store[key] = (result, nbytes)
                self._bytes += nbytes
                while len(self._store) > self.size or self._bytes > self.max_bytes:
                    self._bytes -= self._store.popitem(last=False)[1][1]
        return result

    def __len__(self):
        return len(self._store)

    @property
    def nbytes(self):
        """Bytes of the cached results' arrays."""
        return self._bytes

    def clear(self):
        with self._lock:
            self._store.clear()
            self._bytes = 0


#: The process's one cache of computed results (every session's tabs use it).
SHARED = PanelCache()
