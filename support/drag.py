"""A slider dragged in Chromium, and what the page drew meanwhile (issue 38): shared by
tests/test_drag_browser.py and bench/bench_drag.py, for the dashboard and the floor apps
(bench/floor/drag_*_app.py).

The page is watched through BokehJS's public model API only: every image data source of the
page (the maps' ``map-image`` and ``map-preview`` sources; the floor apps' images) is connected
(``connect(source.properties.data.change, …)``; a map's preview layer when it is added to the
map, on the page's first preview, its first data logged as a change) and each change is logged in the page's clock
(``performance.now()``) with a fingerprint of the new array (sum and count of its finite values,
dtype, byte size) and the time of the animation frame after it: BokehJS repaints a changed plot
in an animation frame it requested while handling the change, before this one (requested after
it), so that frame's time is when the change was painted. Pointer events (down, moves, up) are
logged by capturing listeners on ``document``, and every change of the dragged slider's
``value`` with its new value.
"""

from __future__ import annotations

import time

from support.page import PLOTS_WALK

#: Installs the log (``window.__drag``); ``css``: the css class of the dragged slider's holder.
INSTALL_JS = """(css) => {
  const doc = Bokeh.documents[0];
  const models = Array.from(doc.all_models);
  const log = window.__drag = {changes: [], pointer: [], values: []};
  const fingerprint = (a) => { let s = 0, n = 0;
    for (let i = 0; i < a.length; i++) { const v = a[i]; if (Number.isFinite(v)) { s += v; n++; } }
    return [s, n, String(a.constructor.name), a.byteLength || 0]; };
""" + PLOTS_WALK + """
  let n = 0;
  const hooked = new Set();
  // a layer made after the page (the maps' preview layers, made on the first preview:
  // app/tabs/maps/figures.add_previews) is hooked when it arrives, its first data logged as a change
  const hook = (p, i, r, arriving) => {
    const src = r.data_source;
    if (!src || !src.data || !('image' in src.data || 'pv' in src.data) || hooked.has(src)) return;
    hooked.add(src);
    const column = 'pv' in src.data ? 'pv' : 'image';
    const layer = src.name || 'unnamed';
    n++;
    const changed = () => {
      const t = performance.now();
      const a = src.data[column][0];
      const entry = [t, null, layer, i, ...fingerprint(a)];
      log.changes.push(entry);
      requestAnimationFrame(() => { entry[1] = performance.now(); });
    };
    src.connect(src.properties.data.change, changed);
    if (arriving) changed();
  };
  plots.forEach((p, i) => {
    for (const r of p.renderers) hook(p, i, r, false);
    p.connect(p.properties.renderers.change, () => { for (const r of p.renderers) hook(p, i, r, true); });
  });
  const holder = models.find(m => (m.css_classes || []).includes(css));
  let slider = null; const stack = holder ? [holder] : models;
  while (stack.length && slider === null) {
    const m = stack.pop();
    if (m.type === 'Slider') slider = m;
    for (const c of (m.children || [])) stack.push(Array.isArray(c) ? c[0] : c);
  }
  if (slider === null) slider = models.find(m => m.type === 'Slider' && (m.css_classes || []).includes(css));
  log.slider = slider;
  slider.connect(slider.properties.value.change, () => log.values.push([performance.now(), slider.value]));
  for (const kind of ['pointerdown', 'pointermove', 'pointerup'])
    document.addEventListener(kind, (e) => log.pointer.push([performance.now(), kind]), true);
  return n;
}"""
#: What the log holds (and the slider's value now), for Python.
COLLECT_JS = """() => { const l = window.__drag;
  return {changes: l.changes, pointer: l.pointer, values: l.values, value: l.slider.value,
          now: performance.now()}; }"""
#: Per map (plot), in order: [title, caption, preview layer shown, colour bar low, high].
MAP_TEXTS_JS = """() => {
""" + PLOTS_WALK + """
  return plots.map(p => {
    const below = Array.from(p.below || []);
    const caption = below.find(m => m.text !== undefined && m.color_mapper === undefined);
    const bar = [...Array.from(p.right || []), ...below].find(m => m.color_mapper);
    const pv = p.renderers.find(r => r.data_source && r.data_source.name === 'map-preview');
    return [p.title ? p.title.text : '', caption ? caption.text : '', pv ? pv.visible : null,
            bar ? bar.color_mapper.low : null, bar ? bar.color_mapper.high : null];
  });
}"""


def handle_track(page, css="w-Ph"):
    """(handle centre x, y, track left x, track width) of the slider in ``.{css}``."""
    track = page.locator(f".{css} .noUi-target").first.bounding_box()
    handle = page.locator(f".{css} .noUi-handle").first.bounding_box()
    return (handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2,
            track["x"], track["width"])


def drag(page, fractions, css="w-Ph", step_s=0.016, mid=None):
    """Press the slider's handle, move it through ``fractions`` of its track (one mouse move per
    fraction, ``step_s`` apart), release. ``mid``: called with the page halfway through the moves
    (a screenshot). Returns (pointer down, pointer up) in the page's clock."""
    cx, cy, left, width = handle_track(page, css)
    page.mouse.move(cx, cy)
    page.mouse.down()
    for k, frac in enumerate(fractions):
        page.mouse.move(left + frac * width, cy)
        if mid is not None and k == len(fractions) // 2:
            mid(page)
        time.sleep(step_s)
    page.mouse.up()


def sweep(start, end, moves):
    """``moves`` fractions of the track from ``start`` to ``end`` and back (a hand going to and
    fro), ending at ``end``."""
    half = max(moves // 2, 1)
    out = [start + (end - start) * k / half for k in range(1, half + 1)]
    back = [end - (end - start) * 0.5 * k / half for k in range(1, half + 1)]
    return out + back + [end]


def settled(page, quiet_ms=800.0, timeout=60.0, check=None):
    """Wait until no image source has changed for ``quiet_ms`` and every change is painted (and
    ``check(log)`` holds, if given); return the log (COLLECT_JS)."""
    deadline = time.time() + timeout
    while True:
        log = page.evaluate(COLLECT_JS)
        last = max((c[0] for c in log["changes"]), default=None)
        painted = all(c[1] is not None for c in log["changes"])
        if (last is not None and log["now"] - last >= quiet_ms and painted
                and (check is None or check(log))):
            return log
        if time.time() > deadline:
            raise TimeoutError(f"the page did not settle: {len(log['changes'])} changes")
        time.sleep(0.1)


# ----------------------------------------------------------------------------- a dragged station
#: Installs the Layout design map's log (``window.__design``): every change of its HoloViews
#: image (the exact map) and of its preview layer (app/tabs/design/live.py) as [time, animation frame
#: after it, sum and count of the finite values, length, and for a preview the sequence number
#: of the layout it shows: the design Drag's ``ready`` at the end of the message that brought
#: it]; the layouts the page sent ([time, sequence number]); pointer events. Returns the number
#: of stations drawn, or null when the map has no preview layer.
DESIGN_INSTALL_JS = """() => {
""" + PLOTS_WALK + """
  const pv = views.find(v => v.model.title && v.model.title.text.startsWith('Custom layout'));
  const fig = pv.model;
  const withData = (r) => r.data_source && r.data_source.data;
  const exact = fig.renderers.find(r => withData(r) && 'image' in r.data_source.data
                                        && !String(r.name || '').startsWith('design-preview'));
  const preview = fig.renderers.find(r => r.name === 'design-preview');
  const points = fig.renderers.find(r => withData(r) && 'z' in r.data_source.data && 'x' in r.data_source.data);
  const log = window.__design = {exact: [], previews: [], sends: [], pointer: [], view: pv,
                                 exactLayer: exact, previewLayer: preview, points: points.data_source,
                                 drag: null};
  const fingerprint = (a) => { let s = 0, n = 0;
    for (let i = 0; i < a.length; i++) { const v = a[i]; if (Number.isFinite(v)) { s += v; n++; } }
    return [s, n, a.length]; };
  const watch = (layer, into, seq) => {
    const src = layer.data_source;
    src.connect(src.properties.data.change, () => {
      const a = src.data.image[0];
      if (!a || !a.length) return;
      const entry = [performance.now(), null, ...fingerprint(a), null];
      into.push(entry);
      if (seq) queueMicrotask(() => { entry[5] = log.drag ? log.drag.ready : null; });
      requestAnimationFrame(() => { entry[1] = performance.now(); });
    });
  };
  watch(exact, log.exact, false);
  if (preview === undefined) return null;
  watch(preview, log.previews, true);
  for (const m of Bokeh.documents[0].all_models)
    if (m.properties && m.properties.ready && m.properties.state)  // app.kit.drag.Drag models
      m.connect(m.properties.state.change, () => {
        if (m.state[0] !== 'stations') return;
        log.drag = m;
        log.sends.push([performance.now(), m.state[2]]);
      });
  for (const kind of ['pointerdown', 'pointermove', 'pointerup'])
    document.addEventListener(kind, (e) => log.pointer.push([performance.now(), kind]), true);
  return points.data_source.data.x.length;
}"""
#: Page coordinates of the design map's point (x, y), m.
DESIGN_XY_JS = """([x, y]) => { const pv = window.__design.view, f = pv.frame;
  const r = pv.el.getBoundingClientRect();
  return [r.left + f.x_scale.compute(x), r.top + f.y_scale.compute(y)]; }"""
#: What the design log holds, with the stations, the preview's state, the label over it, the
#: colour bar's range and the title now.
DESIGN_COLLECT_JS = """() => { const l = window.__design, d = l.points.data, fig = l.view.model;
  const label = fig.center.find(m => m.name === 'design-preview-label');
  const mapper = l.exactLayer.glyph.color_mapper;
  return {exact: l.exact, previews: l.previews, sends: l.sends, pointer: l.pointer,
          now: performance.now(), x: Array.from(d.x), y: Array.from(d.y),
          preview_shown: l.previewLayer.visible, label: label ? [label.visible, label.text] : null,
          low: mapper.low, high: mapper.high, title: fig.title.text}; }"""


def design_settled(page, quiet_ms=1000.0, timeout=60.0):
    """The design log once neither layer has changed for ``quiet_ms``, every change painted and
    no preview shown."""
    deadline = time.time() + timeout
    while True:
        log = page.evaluate(DESIGN_COLLECT_JS)
        changes = log["exact"] + log["previews"]
        last = max((c[0] for c in changes), default=-1e12)
        if (log["now"] - last >= quiet_ms and all(c[1] is not None for c in changes)
                and not log["preview_shown"]):
            return log
        if time.time() > deadline:
            raise TimeoutError(f"the design map did not settle: preview shown {log['preview_shown']}")
        time.sleep(0.2)


def station_path(page, start, end, moves):
    """Page coordinates: the press (``start``, m, on a station's marker), then ``moves`` steps
    to ``end`` (m), the first one past BokehJS's 5 px pan threshold at once (a press held
    300 ms without moving is a "press", not a pan, and a loaded machine can take that long
    between two of Playwright's moves)."""
    sx, sy = page.evaluate(DESIGN_XY_JS, list(start))
    tx, ty = page.evaluate(DESIGN_XY_JS, list(end))
    length = max(((tx - sx) ** 2 + (ty - sy) ** 2) ** 0.5, 1e-9)
    first = (sx + (tx - sx) * 8 / length, sy + (ty - sy) * 8 / length)
    return (sx, sy), [first] + [(sx + (tx - sx) * k / moves, sy + (ty - sy) * k / moves)
                                for k in range(1, moves + 1)]
