"""Heavy work of a session off the server's event loop: the one pattern every tab uses.

A computation a user starts from the page (maps, a calibration, Monte-Carlo tracks, the design
optimisers, seed 003's passes) runs on a worker thread of a :func:`pool`; the server's event loop
is only asked to *show* its result. :func:`schedule` puts a coroutine on the session's event loop
(``pn.state.execute`` with the session's document as ``curdoc``), which awaits the worker's future
(``asyncio.wrap_future``) and then changes the page. While it waits, the loop serves every other
session. Outside a server (tests calling a tab's functions) the coroutine runs to completion at
once, so the result is shown before :func:`schedule` returns.

:class:`Task` is that pattern for one part of a page: ``start(key, work, show)`` submits
``work()``, sets ``loading`` on the components it will change (Panel's spinner over them), and
runs ``show(result)`` on the loop in one batch (:func:`changes`); a newer start supersedes an older one
(its result is dropped), and a start with the key being computed or shown does nothing. A failure
of ``work`` goes to ``failed(exc)`` (shown on the page), never up into the server.

Panel's own ``--num-threads`` pool (the README's command, the container and ``app.serve.cluster`` all
pass ``--num-threads 4``) runs the events' watchers; the pools here run the computations, so a
long computation does not take one of the few threads that process other sessions' events.

A change made on the loop goes through :func:`changes`, so that a session's messages leave in
the order they were made (the maps' own Bokeh models are the exception: app/tabs/maps/maps.py). Panel sends a change from its threads as a callback of the
document (Bokeh's queue of the session's writes) but one made on the loop in ``pn.io.hold()``
on a path of its own, which queues it while the socket is busy and then lets later messages
from Bokeh's queue overtake it. A page that first gets a model (a stylesheet Panel's design
adds to a pane on its first update) in the overtaken message then fails on the message that
overtook it ("reference p4070 isn't known": the browser drops that update).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
from functools import partial

import panel as pn
from panel.io.state import set_curdoc

#: Pools by name: one per kind of work, so that a slow kind (a 5 s calibration) never queues a
#: fast one (a 20 ms map) behind it.
_POOLS: dict[str, concurrent.futures.ThreadPoolExecutor] = {}
_POOLS_LOCK = threading.Lock()


def pool(name, workers=2):
    """The worker pool ``name`` (made on first use with ``workers`` threads)."""
    with _POOLS_LOCK:
        if name not in _POOLS:
            _POOLS[name] = concurrent.futures.ThreadPoolExecutor(max_workers=workers,
                                                                 thread_name_prefix=name)
        return _POOLS[name]


def schedule(doc, coroutine_function, *, after_changes=False):
    """Run ``coroutine_function()`` on the event loop of ``doc``'s session (``doc``: the session's
    document, None outside a server), whichever thread calls this.

    ``after_changes``: start it only after the changes of the page's components that this thread
    has made so far reach the page. Off the loop, Panel queues each change for the loop as a
    callback of the document (``add_next_tick_callback``), while a coroutine handed to
    ``pn.state.execute`` may run before them; a result that is ready at once (an input the
    computation refuses) then switched the busy spinner off before its "on" arrived, and the
    spinner stayed on for good. Queued as one more callback of the document, behind them, the
    coroutine starts after them (it then runs, and awaits, without the document's lock)."""
    if doc is None or doc.session_context is None:  # no server: run it here, to the end
        try:
            asyncio.get_running_loop()
        except RuntimeError:  # (Panel would leave a new event loop open for each call)
            asyncio.run(coroutine_function())
            return
    if after_changes:
        def begin():
            with set_curdoc(doc):  # the task keeps this session's curdoc (a context variable)
                asyncio.ensure_future(coroutine_function())

        doc.add_next_tick_callback(begin)
        return
    with set_curdoc(doc):  # this session's: on a Panel worker thread curdoc may be another's
        pn.state.execute(coroutine_function)


def soon(doc, fn):
    """Run ``fn()`` (changes to the page of ``doc``'s session) on the loop as a callback of the
    document, with its lock and its events held, without waiting for it; whichever thread calls
    this. Its messages join Bokeh's queue of the session's writes, in order with the changes from
    Panel's threads (module docstring). For a watcher on Panel's threads that brings new models
    to the page (an input built when it first applies, a tab built on its first visit): made
    there, Panel applies such a change as a callback of the document but inside its own
    ``hold``, on its own path, which a later message from Bokeh's queue could overtake. Outside
    a server, ``fn()`` runs here in ``pn.io.hold()``."""
    if doc is None or doc.session_context is None:
        with pn.io.hold():
            fn()
        return

    def run():
        ours = not doc.callbacks.hold_value  # a hold of another caller's is released by it
        if ours:
            doc.hold("combine")
        try:
            with set_curdoc(doc):
                fn()
        finally:
            if ours:
                doc.unhold()

    doc.add_next_tick_callback(run)


async def changes(doc, fn):
    """Run ``fn()`` (changes to the page of ``doc``'s session) on the loop as a callback of the
    document, with its lock and its events held, and wait for it (:func:`soon`). Outside a
    server, ``fn()`` runs here in ``pn.io.hold()``."""
    if doc is None or doc.session_context is None:
        soon(doc, fn)
        return
    done = asyncio.get_running_loop().create_future()

    def run():
        try:
            fn()
        except BaseException as exc:  # noqa: BLE001 (handed to the awaiting coroutine)
            done.set_exception(exc)
        else:
            done.set_result(None)

    soon(doc, run)
    await done


_NEW = object()


class Task:
    """One part of a page kept current by computations off the event loop (module docstring).

    ``busy``: components whose ``loading`` is set while a computation runs; ``doc``: the
    session's document (default: the current one, at construction)."""

    def __init__(self, pool_name, busy=(), doc=_NEW, workers=2):
        self.pool = pool(pool_name, workers)
        self.busy = tuple(busy)
        self.doc = pn.state.curdoc if doc is _NEW else doc
        #: Panel may run two changes' watchers on two threads at once: a caller that reads the
        #: inputs to decide what to start holds this around the reading and ``start`` (re-entrant),
        #: so each decision sees the values as they then are (not one thread's stale reading
        #: started after another's newer one).
        self.lock = threading.RLock()
        self._key = _NEW
        self._token = None

    def start(self, key, work, show, failed=None):
        """Compute ``work()`` off the loop and ``show(result)`` on it, unless ``key`` is the one
        being computed or shown (None: always compute). Returns the worker's future, or None."""
        with self.lock:
            if key is not None and key == self._key:
                return None
            self._key = key
            token = self._token = object()
            future = self.pool.submit(work)
        self._loading(True)
        schedule(self.doc, partial(self._finish, token, future, show, failed), after_changes=True)
        return future

    def cancel(self):
        """Drop the result being computed (the page keeps what it shows) and forget the key: the
        next start computes, whatever its key. For inputs refused before any computation."""
        with self.lock:
            self._key, self._token = _NEW, None
        self._loading(False)

    def _loading(self, on):
        for component in self.busy:
            component.loading = on

    async def _finish(self, token, future, show, failed):
        try:
            result = await asyncio.wrap_future(future)
        except Exception as exc:  # noqa: BLE001 (said on the page; the server goes on)
            if token is self._token:
                self.cancel()
                if failed is not None:
                    failed(exc)
            return
        if token is not self._token:  # a newer start shows its own
            return
        def apply():
            try:
                show(result)
            finally:
                self._loading(False)

        await changes(self.doc, apply)


__all__ = ["Task", "changes", "pool", "schedule", "soon"]
