"""Where a map update's time goes inside the server (issue 40): timestamps per leg, collected only
when asked.

``APP_TIMINGS=<path>`` in the server's environment turns it on (bench/load_test.py sets it): each
change of the maps' inputs (app/tabs/maps/maps.py ``redraw``) becomes one record of timestamps, one per leg
below, appended to ``<path>`` as a line of JSON when the update ends (sent, or dropped). Off (the
default) every stamp is one test of a module attribute, and nothing is registered anywhere.

Timestamps are ``time.perf_counter()``: on Linux CLOCK_MONOTONIC, one clock for every process of
the machine, so a client's own stamps (its send, the answer's arrival) line up with them.

The legs, in order (``LEGS``):

``arrived``    Bokeh has applied the client's change to the session's document (on the event
               loop; the document's public ``on_change``: the latest change from a client before
               the update's handler starts)
``handler``    the maps' watcher starts (``redraw``): after Panel's 50 ms debounce of a widget
               change, the wait for the loop to run it and for one of Panel's threads
``submitted``  the compute is handed to the maps' pool (app/tabs/maps/maps.py ``_COMPUTE``)
``started``    a thread of that pool starts it
``locked``     it holds the kernel lock (app.kit.cache.KERNEL_LOCK: kernels run one at a time)
``unlocked``   the kernels are done (lock released)
``computed``   the rest of the maps (notes, difference, colour ranges) and the arrays to send
``resumed``    the event loop resumes the session's draw (the wait for the loop)
``drawn``      the maps' Bokeh models are updated (app.tabs.maps.figures.fill)
``sent``       the patch is serialised and written to the websocket (the end of ``pn.io.hold()``)

A record also holds the process id, the session id, the inputs that changed (name -> value, for a
client to match its own update) and ``outcome``: ``sent``; ``superseded`` (a newer change of the
session draws its own maps); ``unchanged`` (the inputs are those already drawn or being drawn:
nothing to do); ``failed``. A leg that did not happen (a result from the cache: no lock) is
absent.
"""

from __future__ import annotations

import json
import os
import threading
import time
import weakref

#: The environment variable that names the file of records (none: off).
ENV = "APP_TIMINGS"
#: The legs of an update, in order (module docstring).
LEGS = ("arrived", "handler", "submitted", "started", "locked", "unlocked", "computed", "resumed",
        "drawn", "sent")

PATH = os.environ.get(ENV) or None
#: Whether records are collected (read once, at import: the server's environment).
ENABLED = PATH is not None

_write_lock = threading.Lock()
_local = threading.local()
#: The time of the latest change a client made to each session's document.
_arrivals: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def watch_arrivals(doc):
    """Stamp every change a client makes to ``doc`` (a session's document): the ``arrived`` leg.
    A no-op when off or outside a server."""
    if not ENABLED or doc is None or doc.session_context is None:
        return
    now = time.perf_counter

    def arrived(event):
        if getattr(event, "setter", None) is not None:  # applied from a client's message
            _arrivals[doc] = now()

    doc.on_change(arrived)


def start(doc):
    """A new record for an update of ``doc``'s maps, its ``handler`` stamped now and ``arrived``
    from the session's latest client change; None when off. The caller adds ``changed``."""
    if not ENABLED:
        return None
    t = time.perf_counter()
    rec = {"pid": os.getpid(), "session": _session_id(doc), "changed": {}, "handler": t}
    arrived = _arrivals.get(doc) if doc is not None else None
    if arrived is not None and arrived <= t:
        rec["arrived"] = arrived
    return rec


def _session_id(doc):
    ctx = getattr(doc, "session_context", None)
    return getattr(ctx, "id", None)


def stamp(rec, leg):
    """Stamp ``leg`` of ``rec`` now (``rec`` None: off, nothing)."""
    if rec is not None:
        rec[leg] = time.perf_counter()


class current:
    """``with current(rec):`` makes ``rec`` the record of this thread, for :func:`stamp_current`
    in code that does not get the record (the kernel lock inside app.tabs.maps.compute.compute)."""

    def __init__(self, rec):
        self.rec = rec

    def __enter__(self):
        self.before = getattr(_local, "rec", None)
        _local.rec = self.rec
        return self.rec

    def __exit__(self, *exc):
        _local.rec = self.before
        return False


def stamp_current(leg):
    """Stamp ``leg`` of this thread's record (:class:`current`), if any."""
    if ENABLED:
        stamp(getattr(_local, "rec", None), leg)


def finish(rec, outcome):
    """End ``rec`` with ``outcome`` and append it to the file (``rec`` None: off, nothing)."""
    if rec is None:
        return
    rec["outcome"] = outcome
    line = (json.dumps(rec, default=_plain) + "\n").encode()
    with _write_lock:
        fd = os.open(PATH, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, line)  # one write of one line, O_APPEND: replicas may share the file
        finally:
            os.close(fd)


def _plain(value):
    if isinstance(value, tuple):
        return list(value)
    return str(value)


def read(path):
    """The records in the file ``path`` (a missing file: none)."""
    try:
        with open(path, encoding="utf-8") as fh:
            return [json.loads(line) for line in fh if line.strip()]
    except FileNotFoundError:
        return []


__all__ = ["ENABLED", "ENV", "LEGS", "current", "finish", "read", "stamp", "stamp_current", "start",
           "watch_arrivals"]
