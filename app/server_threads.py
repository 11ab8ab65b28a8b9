"""Process-wide settings for serving many sessions from threads (imported by app/main.py)."""

from __future__ import annotations

import sys

import panel as pn
from bokeh.server.views.ws import WSHandler

#: A map is computed on a worker thread while Panel's Python runs on others; the worker gives up
#: the GIL in every numpy/numba call and, with Python's default 5 ms switch interval, may wait
#: that long to get it back each time (the compute took 3–5× its in-process time inside the
#: server). 0.5 ms lets it resume promptly.
SWITCH_INTERVAL = 0.0005


def _not_counted(self, *args, **kwargs):
    """Stands in for Panel's busy counting (see :func:`drop_process_wide_busy_flag`)."""


def drop_process_wide_busy_flag():
    """Panel counts every event of every session into ``pn.state.busy``, one flag for the whole
    process that only a template's busy indicator reads (``pn.state.sync_busy``); this app has
    none (``busy_indicator=None``: each session has its own spinner). Counting cost ~5 ms of
    Python per browser event (each add or remove lifts and restores the read-only flag of every
    parameter of ``pn.state``; a P_h release with its last drag step took 22 ms of Panel's Python
    with it, 10-15 ms without), and it was not thread-safe: two worker threads
    (``--num-threads``) interleaving there restored "read-only" under each other and the event
    being processed failed with "Read-only parameter 'busy' cannot be modified" (seen in the
    load test: an update never answered). So the events are not counted."""
    cls = type(pn.state)
    for name in ("_add_busy_event", "_remove_busy_event", "_cleanup_busy_counter"):
        setattr(cls, name, _not_counted)


#: Bokeh's own ``WSHandler.open`` (see :func:`send_without_delay`).
_BOKEH_OPEN = WSHandler.open


def _open_without_delay(self):
    self.set_nodelay(True)
    return _BOKEH_OPEN(self)


def send_without_delay():
    """Bokeh writes every message as several websocket frames (header, metadata, content, one per
    binary buffer) and leaves Nagle's algorithm on, so a frame after the first may wait for the
    peer's delayed ACK (40 ms). Seen from the other end: the frames of each message from a Bokeh
    client reached the server 41.7 ms apart (the load test's clients now set TCP_NODELAY, as a
    browser does). The server's own messages to the browser have the same shape, so each
    session's socket sends at once too."""
    WSHandler.open = _open_without_delay


def configure():
    sys.setswitchinterval(SWITCH_INTERVAL)
    drop_process_wide_busy_flag()
    send_without_delay()
