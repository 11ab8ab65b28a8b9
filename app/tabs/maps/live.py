"""Maps that follow a dragged slider (issue 38): coarse previews while the hand moves, the exact
maps on release.

The page's sliders report on release only (``pn.extension(throttled=True)``: app/page.py),
and Panel delays every widget change by 50 ms before Python sees it. While a slider of the maps'
inputs is dragged, the path here is shorter, through public Bokeh and Panel only:

* in the browser, a ``CustomJS`` on the slider's ``value`` (Panel's ``jscallback``) offers
  ``[input, value, sequence, released]`` to :class:`app.kit.drag.Drag`, a Bokeh ``DataModel`` of the session,
  only while a hand is down on the page (:data:`app.kit.drag.HAND_JS`, on the document's
  ``document_ready``): a typed value, a link or a preset moves the handle from the server, and is
  not offered. Through a closed loop (:data:`app.kit.drag.LOOP_JS`): a value goes out once the server has answered the
  previous one (``Drag.ready``, set with the preview it drew, in the same message), and at most
  one every THROTTLE_MS (the first of a gesture THROTTLE_MS after it: a click on the track or a
  flick is released before then, and computes no preview); meanwhile the latest value waits in
  the page and replaces older ones. A busy server therefore gets no queue of values, only the
  latest one when it can take it. When the hand lets go (:data:`app.kit.drag.HAND_JS`, installed with the
  page: Panel's ``jscallback`` does not offer the slider's ``value_throttled``), the dragged
  slider's final value is written at once, ``released`` set; ``APP_PREVIEWS=off`` in the server's environment turns all of this off (:data:`PREVIEWS`);
* on the server, Bokeh's ``on_change`` of that model runs :meth:`Live.changed` on the event loop
  as the message arrives (no debounce). A preview is computed off the loop at PREVIEW_N² points
  (fewer when that takes longer than PREVIEW_BUDGET_S: :func:`app.kit.drag.next_n`) of the handle's value,
  not the scenario's (:meth:`app.state.snapshot.Snapshot.of_values`), and drawn
  into each map's preview layer: uint8 levels colour-mapped in the browser (app/tabs/maps/figures.py),
  veils uint8 and sent only when they change, colour bars, titles (" — preview") and captions
  (their "grid n × n") of the value under the handle. A session computes one preview at a
  time; values arriving meanwhile (the page sends one early only when an answer is over
  PATIENCE_MS late) replace each other, and the latest is computed next. Every value is
  answered (``Drag.ready``): drawn, replaced or refused;
* on release the value is set on the scenario at once (Panel's own ``value_throttled``, 50 ms
  later, then changes nothing), which draws the exact maps through app/tabs/maps/maps.py as any change
  does; a preview still computing is dropped. A release where the scenario does not change
  (the hand came back, or the value is refused) redraws the exact maps of the scenario as it is.

A change of the slider made by the server (a preset, a typed value, a link) moves the handle in
the browser with no hand down: it is not offered, and the scenario's exact maps are all that is
computed; on the server too, a value the scenario already holds is not previewed unless a drag
of it is under way. Nothing is previewed while the Maps tab is hidden.
"""

from __future__ import annotations

import asyncio
import time
import weakref
from functools import partial

import panel as pn
import param
from bokeh.models import CustomJS

from app.kit import number_box, offloop
from app.kit.drag import (
    FOLLOW_JS,
    HAND_JS,
    PATIENCE_MS,
    PREVIEW_N,
    PREVIEWS,
    THROTTLE_MS,
    answer,
    drag_model,
    next_n,
)
from . import data as map_data, figures as map_figures
from .compute import MAP_INPUTS, Snapshot, compute

#: Previews of every session, off the event loop (core runs one kernel at a time anyway).
_PREVIEWS = offloop.pool("previews", 2)

#: The live part of each open session's page, by its document (dropped when the session ends).
_SESSIONS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class Live:
    """Previews of one session's maps while a slider is dragged (module docstring).

    ``figs``: the Maps tab's :class:`app.tabs.maps.figures.MapFigures`; ``exact()``: draws the exact
    maps of the scenario as it is, even when they were drawn before (app/tabs/maps/maps.py)."""

    def __init__(self, scenario, figs, doc, exact):
        self.scenario, self.figs, self.doc, self.exact = scenario, figs, doc, exact
        self.drag = drag_model()
        self.drag.on_change("state", self.changed)
        self.shown = True  # the Maps tab is the active one
        self.dragging = None  # the input being dragged, from its first preview to its release
        self.previewed = False  # a preview is drawn (and not yet replaced by exact maps)
        self.pending = None  # the latest (input, value) not yet computed
        self.computing = False
        self.generation = 0  # a release starts a new one: previews of an older one are dropped
        self.drawn = 0  # previews drawn (for tests and the benchmark)
        self.preview_n = PREVIEW_N  # points per axis of the next preview (PREVIEW_BUDGET_S)
        self.boxes = {}  # input -> its number box, which shows the value previewed (follow)
        if doc is not None and doc.session_context is not None:
            doc.js_on_event("document_ready", CustomJS(  # with the page (FOLLOW_JS)
                args=dict(drag=self.drag, throttle=THROTTLE_MS, patience=PATIENCE_MS), code=HAND_JS))
            _SESSIONS[doc] = self
            doc.on_session_destroyed(lambda _ctx: self.close())

    def changed(self, _attr, _old, new):
        if len(new) != 4 or not isinstance(new[2], int):
            return
        name, value, seq, released = new
        if name not in MAP_INPUTS or not isinstance(value, (int, float)) or isinstance(value, bool):
            answer(self.drag, seq)
            return
        owner = self.scenario.part_of(name)
        # Whole numbers for an Integer input only: the type of the value a Number input holds
        # says nothing (a link's or a release's 151 arrives as int 151), and rounding there set
        # P_h = 263 on the release of 263.2, then Panel's own release set 263.2: the maps ended
        # at 263.2, the slider's handle at 263 (and a drag's previews were rounded too)
        if isinstance(owner.param[name], param.Integer):
            value = int(round(value))
        if released:
            self.release(owner, name, value)
            answer(self.drag, seq)
        elif self.shown and (self.dragging == name or value != getattr(owner, name)):
            self.dragging = name
            if self.pending is not None:  # replaced by a newer value: answered with it
                answer(self.drag, self.pending[2])
            self.pending = (name, value, seq)
            if not self.computing:
                self._start()
        else:
            answer(self.drag, seq)

    def release(self, owner, name, value):
        """The final value: set on the scenario now (the exact maps follow); previews dropped."""
        self.generation += 1
        self.pending, self.dragging = None, None
        before = Snapshot.of(self.scenario)
        setattr(owner, name, value)  # the scenario may refuse it and keep its value
        number_box.show(self.boxes.get(name), getattr(owner, name))  # what it holds, not a preview
        if self.previewed and Snapshot.of(self.scenario) == before:
            self.exact()  # nothing changed, so nothing redraws: the previews must go

    def _start(self):
        name, value, seq = self.pending
        self.pending, self.computing = None, True
        scenario = self.scenario
        n = min(self.preview_n, int(scenario.value("resolution")))
        try:
            snapshot = Snapshot.of_values(scenario, {name: value, "resolution": n})
        except (KeyError, ValueError):
            self.computing = False
            answer(self.drag, seq)
            return
        future = _PREVIEWS.submit(_preview, snapshot)
        offloop.schedule(self.doc, partial(self._finish, self.generation, future, n, seq, name, value))

    async def _finish(self, generation, future, n, seq, name=None, value=None):
        try:
            prepared, seconds = await asyncio.wrap_future(future)
        except Exception:  # noqa: BLE001 (a value the scenario would refuse: no preview)
            prepared = None
        else:
            self.preview_n = next_n(n, seconds)
        self.computing = False
        if self.scenario is None:  # the session ended while the preview was computed
            return
        # the maps' own models and the answer in one message; on the loop, outside a callback
        # of the document, a Bokeh model is changed only in pn.io.hold() (else Bokeh's session
        # raises: its writes are prepared under the document's lock)
        with pn.io.hold():
            if prepared is not None and generation == self.generation and self.shown:
                map_figures.fill(self.figs, prepared)
                number_box.show(self.boxes.get(name), value)  # the box says what the maps show
                self.previewed = True
                self.drawn += 1
            answer(self.drag, seq)
            if self.pending is not None:
                self._start()

    def close(self):
        """The session ended: forget it, and cut what its sliders' browser-side callbacks keep.

        Panel's ``Callback.registry`` is keyed weakly by the slider, but its entry holds the
        callback's ``args`` (``drag``), whose ``on_change`` held this object, hence the scenario,
        whose watchers hold the slider: every closed session stayed alive
        (tests/test_server_memory.py). Panel < 1.9 has no ``Callback.unwatch``; removing the
        ``on_change`` callback and this object's references cuts the cycle on every version."""
        _SESSIONS.pop(self.doc, None)
        self.drag.remove_on_change("state", self.changed)
        self.scenario = self.figs = self.doc = self.exact = None
        self.boxes = {}

    def drawn_exact(self):
        """Called by app/tabs/maps/maps.py when it has drawn exact maps: no preview is shown, and none
        computed before them is drawn over them."""
        self.previewed = False
        self.generation += 1


def _preview(snapshot):
    """(the preview's arrays, seconds its compute took): on a worker thread."""
    t0 = time.perf_counter()
    panels = compute(snapshot)
    seconds = time.perf_counter() - t0
    return map_data.prepare(panels, preview=True), seconds


def follow(slider, name, box=None):
    """Make the Panel ``slider`` of input ``name`` drive the current session's previews (a no-op
    for an input the maps do not read, a page without a Maps tab, or previews off: PREVIEWS);
    ``box`` (app.kit.number_box) shows the value a preview draws."""
    live = _SESSIONS.get(pn.state.curdoc) if pn.state.curdoc is not None else None
    if live is None or not PREVIEWS or name not in MAP_INPUTS:
        return
    live.boxes[name] = box
    args = dict(drag=live.drag, name=name, throttle=THROTTLE_MS, patience=PATIENCE_MS)
    slider.jscallback(args=args, value=FOLLOW_JS)


def shown_with(tabs, index):
    """Previews only while tab ``index`` of ``tabs`` (the Maps tab) is the active one."""
    live = _SESSIONS.get(pn.state.curdoc) if pn.state.curdoc is not None else None
    if live is None:
        return

    def active(event):
        live.shown = event.new == index
        if not live.shown and live.pending is not None:
            answer(live.drag, live.pending[2])
            live.pending = None

    live.shown = tabs.active == index
    tabs.param.watch(active, ["active"])


__all__ = ["Live", "follow", "shown_with"]
