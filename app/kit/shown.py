"""A hidden tab computes nothing: what it would redo on a change is redone when it is shown.

The Layout design and Track tabs, once built (:func:`app.page.first_visit`), watch the
shared scenario. Hidden, they recomputed on every change: a preset clicked on the Maps tab held
its thread 6-20 s for their CRLB map and Monte-Carlo, and the Maps tab's banner, note and the
address bar, queued behind that work, lagged the maps by 20-30 s (issue 40, defect 3).
:class:`WhenShown` wraps such a watcher: while its tab is hidden a call only marks it due; the
due calls run once each, in order, when the tab is shown (through ``later``, where it differs:
a refresh that computes off the event loop with a busy spinner over what it will change).
"""

from __future__ import annotations

import threading


class WhenShown:
    """The calls of tab ``index`` of ``tabs`` (a ``pn.Tabs``), held while another tab is shown.
    Without ``tabs`` (a tab built on its own, in a test) the tab counts as always shown."""

    def __init__(self, tabs=None, index=None):
        self.index = index
        self.shown = tabs is None or tabs.active == index
        self._due = {}  # the functions to run on the next show, in order (a dict: each once)
        self._lock = threading.Lock()
        if tabs is not None:
            tabs.param.watch(self._switched, ["active"])

    def __call__(self, fn, later=None):
        """``fn`` as a watcher (called with a change's events): run at once while the tab is
        shown, else ``later()`` (default ``fn()``) once when the tab is next shown."""
        def gated(*events):
            with self._lock:
                if not self.shown:
                    self._due[later or fn] = None
                    return
            fn(*events)

        return gated

    def _switched(self, event):
        with self._lock:
            self.shown = event.new == self.index
            due = list(self._due) if self.shown else []
            if self.shown:
                self._due.clear()
        for fn in due:
            fn()


#: For a tab that is always shown (built alone, outside the page).
ALWAYS = WhenShown()

__all__ = ["ALWAYS", "WhenShown"]
