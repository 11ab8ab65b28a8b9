"""A dragged slider's or station's closed loop with the server (issue 38), shared by the tabs
whose maps follow a drag (the Maps tab: app/tabs/maps/live.py; the Layout design tab's stations:
app/tabs/design/live.py).

The page sends a value once the server has answered the previous one, at most one every
THROTTLE_MS (:data:`LOOP_JS`); the server answers every value (:func:`answer`), drawn, replaced
or refused, and sizes its previews to a budget of compute (:func:`next_n`). A slider's value is
offered only while a hand is down on the page (:data:`FOLLOW_JS`, :data:`HAND_JS`: a typed value,
a link or a preset moves the handle from the server and is not previewed), and its final value
goes out when the hand lets go (issue 46 item 3).
"""

from __future__ import annotations

import os

from bokeh.core.properties import Any, Int, List
from bokeh.model import DataModel
from bokeh.models import CustomJS

#: Shortest interval (ms) between two values a dragged slider (or station) sends.
THROTTLE_MS = 40
#: How long (ms) the page waits for the server's answer to a value before it sends the next one
#: anyway (a guard: every value is answered).
PATIENCE_MS = 1000
#: Points per axis of a preview (at most the scenario's resolution), and the fewest it may
#: come down to (:data:`PREVIEW_BUDGET_S`).
PREVIEW_N, PREVIEW_MIN_N = 100, 30
#: Seconds of compute a preview may take: a slower one (a loaded machine; a 100² preview takes
#: 4 ms for the paper's electric map and 13–23 ms for the magnetic kinds' CRLB maps on a quiet
#: one, docs/performance.md) makes the next previews coarser, so the maps
#: still follow the hand (and hold the kernels, which every session shares, for less long); a
#: fast one lets the grid grow back to PREVIEW_N.
PREVIEW_BUDGET_S = 0.06

#: Whether dragged sliders and stations are previewed: ``APP_PREVIEWS=off`` in the server's
#: environment turns them off (the maps wait for the release), for a replica that serves many
#: analysts on few cores: a short drag's previews cost ~70–80 ms of server CPU (docs/performance.md).
PREVIEWS = os.environ.get("APP_PREVIEWS", "on").strip().lower() not in ("off", "0", "no", "false")


class Drag(DataModel):
    """What the browser says about a dragged slider or station: ``state``, ``[input name, value,
    sequence number, released]`` (one property: one message and one server callback per
    value); and the server's answer, ``ready``: the sequence number of the latest value it is
    done with (drawn, replaced or refused), which lets the page send the next one."""

    state = List(Any, default=[])
    ready = Int(default=0)


#: The page's closed loop for one :class:`Drag` (``drag``; ``throttle``, ``patience``: ms), at
#: the head of every browser-side callback that uses it: ``loop.offer(name, value)`` keeps the
#: latest value and sends it when the server has answered the previous one (``drag.ready``) and
#: ``throttle`` ms have passed since it (``patience`` ms when unanswered);
#: ``loop.release(name, value)`` sends a final value at once; ``loop.pump()`` (on ``ready``)
#: sends what waits.
LOOP_JS = """
const loops = window.__liveLoops || (window.__liveLoops = new WeakMap());
let loop = loops.get(drag);
if (loop === undefined) {
  loop = {seq: 0, sent: 0, at: -1e9, pending: null, timer: null};
  loop.send = (name, value, released) => {
    loop.seq += 1; loop.sent = loop.seq; loop.at = performance.now();
    drag.state = [name, value, loop.seq, released];
  };
  loop.pump = () => {
    if (loop.timer !== null) { clearTimeout(loop.timer); loop.timer = null; }
    if (loop.pending === null) return;
    const answered = drag.ready >= loop.sent;
    const wait = loop.at + (answered ? throttle : patience) - performance.now();
    if (wait > 0) { loop.timer = setTimeout(loop.pump, wait); return; }
    const [name, value] = loop.pending;
    loop.pending = null;
    loop.send(name, value, false);
  };
  loop.offer = (name, value) => {
    // a gesture's first value waits one throttle: a click on the track, or a flick, is released
    // within it (the release drops it), so no preview is computed only to be thrown away
    const now = performance.now();
    if (loop.pending === null && drag.ready >= loop.sent && now - loop.at > throttle) loop.at = now;
    loop.pending = [name, value];
    loop.pump();
  };
  loop.drop = () => {
    if (loop.timer !== null) { clearTimeout(loop.timer); loop.timer = null; }
    loop.pending = null;
  };
  loop.release = (name, value) => { loop.drop(); loop.send(name, value, true); };
  loops.set(drag, loop);
}
"""

#: In the slider's browser-side callback (``source``: the slider's model; ``drag``: the session's
#: :class:`Drag`; ``name``: the input): the value into the loop; its release at once.
FOLLOW_JS = LOOP_JS + """
// a value is previewed only while the hand is down on the page and moving it (HAND_JS): a
// typed value, a link or a preset moved the handle from the server and is the scenario's
// already: exact maps only (issue 46 item 3)
if (!(window.__liveHand && window.__liveHand.down)) return;
loop.dragging = name;
loop.source = source;
loop.offer(name, source.value);
"""

#: On the document's ``document_ready`` (installed with the page; ``drag``, ``throttle``,
#: ``patience`` as LOOP_JS's): whether a hand (mouse, pen, finger) is down on the page; when it
#: lets go, the dragged slider's final value at once (its release: a click on the track too).
HAND_JS = LOOP_JS + """
if (window.__liveHand === undefined) {
  const hand = window.__liveHand = {down: false};
  const up = () => {
    hand.down = false;
    setTimeout(() => {  // after the slider's own handling of this event: its final value
      if (!loop.dragging) return;
      const name = loop.dragging;
      loop.dragging = null;
      loop.release(name, loop.source.value);
    }, 0);
  };
  document.addEventListener("pointerdown", () => { hand.down = true; }, true);
  document.addEventListener("pointerup", up, true);
  document.addEventListener("pointercancel", up, true);
}
"""

#: On a change of ``drag.ready`` (the server's answer): what waits goes out.
READY_JS = LOOP_JS + "loop.pump();"


def drag_model():
    """A :class:`Drag` whose ``ready`` sends what the page's loop holds (:data:`LOOP_JS`)."""
    drag = Drag()
    drag.js_on_change("ready", CustomJS(args=dict(drag=drag, throttle=THROTTLE_MS, patience=PATIENCE_MS),
                                        code=READY_JS))
    return drag


def answer(drag, seq):
    """Tell the page the server is done with value ``seq`` (and every earlier one)."""
    if seq > drag.ready:
        drag.ready = seq


def next_n(n, seconds):
    """Points per axis of the next preview after one of ``n`` took ``seconds``: the compute
    grows as n², so n scaled by √(budget / seconds), within PREVIEW_MIN_N … PREVIEW_N; kept
    when within a factor 2 of the budget (no back and forth on noise)."""
    if PREVIEW_BUDGET_S / 2 <= seconds <= PREVIEW_BUDGET_S * 2:
        return n
    scaled = int(round(n * (PREVIEW_BUDGET_S / max(seconds, 1e-4)) ** 0.5 / 10.0) * 10)
    return max(PREVIEW_MIN_N, min(PREVIEW_N, scaled))
