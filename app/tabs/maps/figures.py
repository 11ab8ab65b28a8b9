"""The three comparison maps (A, B, difference) as plain Bokeh figures, updated in place.

HoloViews rebuilt every element on each change and sent each map separately (about a second per
slider release, measured by bench/bench_browser.py); here the figures are built once and a change
only replaces the float32 image arrays, the colour bars' ranges and the texts.

Colour ranges. BokehJS colour-maps an image again on every change event of its colour mapper
(twice: the mapper re-emits ``change`` after rescanning), and with the old image when the range
comes before the data. So the images' mappers never change range: an image is sent *normalised*
to its colour range (0 at the low end, 1 at the high end; :func:`normalised`) and its mapper
spans 0 … 1 for good. Only the colour bars' mappers, which draw no image, get the real range; the
hover turns a normalised value back into the real one with the same range. One colour-mapping
per image per change, through public Bokeh only.

Every layer of a map (value, veil) always covers the same rectangle as the map (issue 16, defect
1: the veil was re-sent only when its image or x changed, and stayed where the last plane had it).
Veils are uint8 codes, sent only when they change.

Previews (issue 38, app/tabs/maps/live.py). While a slider is dragged, each map's preview layer (over the
map, under its veil) shows a coarser grid as uint8 levels of the colour range (:func:`quantised`),
colour-mapped in the browser by a mapper of its own (0 … PREVIEW_TOP, PREVIEW_NAN drawn white);
:func:`fill` with a ``prepare(p, preview=True)`` draws it, the exact maps hide it. The layers
are made on a page's first preview (:func:`add_previews`), not with the page: most sessions
never drag, and the three layers are 18 of a page's Bokeh models (issue 40 item 3).

Aspect (issue 25). A metre is as long across as up on an x–y map: the ranges are Bokeh
``DataRange1d`` fitted to the view box (:func:`view_box`, corners drawn invisibly) with the
figures' ``match_aspect``, so BokehJS widens one range until the frame's pixel aspect is the
data's, at any width of the page (the frames were ~130 × 190 px over ±300 m square, circles drawn
as upright ellipses). An x–z section (often far wider than deep) is drawn with a stated vertical
exaggeration, a round number (:func:`exaggeration`) in its z axis label, set through
``aspect_scale``. The colour bar lies under the map, not beside it: the map is wider, and the
bar's labels no longer touch the frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from bokeh.models import (
    BasicTicker,
    BoxZoomTool,
    ColorBar,
    ColumnDataSource,
    CustomJSHover,
    CustomJSTickFormatter,
    DataRange1d,
    GlyphRenderer,
    HoverTool,
    Image,
    Label,
    LinearColorMapper,
    SaveTool,
    Scatter,
    Title,
)
from bokeh.core.properties import Bool, String
from bokeh.core.property.validation import validate
from bokeh.model import DataModel
from bokeh.palettes import Viridis256

from app.kit.runaway import RUNAWAY_LIMIT

from .data import (
    NAN_COLOUR,
    PREVIEW_TOP,
    VEIL_PALETTE,
    Prepared,
    exaggeration,
    geometry,
    prepare,
    veiled_text,
    view_box,
    wrapped,
)

#: The hover of a map, on its veil layer (a veil code is never NaN: Bokeh shows a NaN value as
#: "NaN" without asking the formatter): what the point is, or its value, the normalised image
#: value (``img``: the map's data source) turned back with the colour range of its colour bar's
#: mapper ``bar`` (kept current with the range), its words and scale from ``texts`` (a
#: :class:`HoverTexts`). The args themselves never change: setting args, which refer to models,
#: makes Bokeh re-walk the whole document (on the server, and in every client), 0.1–0.3 s of the
#: event loop per map on a change of measure.
_HOVER_JS = """
if (value == 1 || value == 2) return texts.unobservable;
const s = img.data.image[0][special_vars.image_index.flat_index];
if (s == null || !isFinite(s)) return texts.none;
const v = bar.low + s * (bar.high - bar.low);
const far = value >= 4 ? texts.runaway : "";
if (texts.log) { const m = Math.pow(10, v); return (m < 1e4 ? m.toPrecision(3) : m.toExponential(2)) + " m" + far; }
return v.toFixed(3) + far;
"""
#: Colour bar ticks: in metres on a log10-metre scale (``log``), else the plain number. One
#: formatter per bar, switched by its args (BokehJS keeps a colour bar's first formatter). On a
#: log bar one notation for all its ticks (:func:`app.tabs.maps.data.tick_texts`: "100" beside "1e+4" read as two
#: scales).
_TICK_JS = """
if (!log) return String(Number(tick.toPrecision(6))).replace("-", "\u2212");
const powers = ticks.some(t => Math.pow(10, t) >= 1e4 || Math.pow(10, t) < 1e-2);
const m = Math.pow(10, tick);
if (!powers) return String(Number(m.toPrecision(2)));
const [c, e] = m.toExponential(0).split("e");
const sup = String(Number(e)).replace(/[0-9-]/g, d => "\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079\u207b"["0123456789-".indexOf(d)]);
return (c === "1" ? "" : c + "\u00d7") + "10" + sup;
"""

#: Hover text after the value of a runaway point (app.kit.runaway.runaway).
RUNAWAY_TEXT = (f" — over {RUNAWAY_LIMIT:.0%} of the range to the nearest station: the linearised "
                "bound does not predict a tracker's error here (far-field runaway)")
RUNAWAY_DIFF_TEXT = f" — A's or B's CRLB is over {RUNAWAY_LIMIT:.0%} of the range (far-field runaway)"


class HoverTexts(DataModel):
    """What a map's hover says besides its value, and whether the value is log10 metres: changed
    with the measure or the layout, in properties of their own (a change of them is one small
    message and no walk of the document, unlike a change of the formatter's ``args``)."""

    log = Bool(default=False)
    unobservable = String(default="")
    none = String(default="")
    runaway = String(default="")


@dataclass
class MapFigures:
    """Bokeh models of the three maps; :func:`fill` writes a :class:`Panels` into them."""

    layout: tuple  # the three figures, for a row or grid of the caller's
    figures: tuple
    images: tuple  # ColumnDataSource per map: image, x, y, dw, dh
    veils: tuple
    stations: tuple
    bar_mappers: tuple  # of the colour bars: A and B share the first; the difference has the second
    colorbars: tuple
    hovers: tuple
    formatters: tuple  # CustomJSHover of each map's value
    captions: tuple
    saves: tuple
    labels: tuple = ()  # per map: a Label inside its frame, shown when it is veiled everywhere
    view: object = None  # the (plane, view box, exaggeration) last drawn: a new one resets zoom and pan
    view_source: object = None  # the view box's corners, drawn invisibly: the ranges fit them
    previews: tuple = ()  # per map: the preview layer's data source (app/tabs/maps/live.py), column ``pv``
    preview_layers: tuple = ()  # per map: its renderer, shown only while previews are drawn


#: The captions under the maps (the scenario's parameters) and the label of a veiled map.
CAPTION_PX, CAPTION_COLOUR = "12px", "#2b2b2b"

#: The figures' size before scaling to the page's width (``scale_width``): frames within ~8 % of square
#: from ~300 px per map (a 1280 px screen) to ~400 (1600 px); ``match_aspect`` keeps
#: a metre square either way, widening one range).
WIDTH, HEIGHT = 420, 560


def _figure(x_range, y_range):
    from bokeh.plotting import figure

    fig = figure(x_range=x_range, y_range=y_range, width=WIDTH, height=HEIGHT, sizing_mode="scale_width",
                 tools="pan,wheel_zoom,reset", match_aspect=True, title="",
                 background_fill_color="white", border_fill_color="white", min_border_left=56,
                 min_border_right=12, toolbar_location="right")
    box_zoom = BoxZoomTool(match_aspect=True)  # a box zoom keeps the aspect too
    fig.add_tools(box_zoom)
    fig.title.text_font_size = "10pt"
    fig.xaxis.ticker.desired_num_ticks = 4  # labels of a narrow map (1280 px screen) must not run together
    fig.toolbar.autohide = True
    return fig


def _ranges():
    """Fresh ranges (BokehJS fits them again: a new view forgets the user's zoom)."""
    return DataRange1d(range_padding=0), DataRange1d(range_padding=0)


def build():
    """Three empty linked maps (one shared x and y range: zoom and pan together)."""
    x_range, y_range = _ranges()
    view_source = ColumnDataSource(dict(x=[-1.0, 1.0], y=[-1.0, 1.0]), name="map-view")
    corners = []
    value_bar, diff_bar = (LinearColorMapper(palette=Viridis256, low=0, high=1, nan_color=NAN_COLOUR)
                           for _ in range(2))
    veil_mapper = LinearColorMapper(palette=list(VEIL_PALETTE), low=0, high=len(VEIL_PALETTE) - 1)
    out = {k: [] for k in ("figs", "images", "veils", "stations", "bars", "hovers", "formatters",
                           "captions", "saves", "labels")}
    for which in range(3):
        fig = _figure(x_range, y_range)
        # The images' mapper spans 0 … 1 for good (images come normalised: module docstring).
        mapper = LinearColorMapper(palette=Viridis256, low=0, high=1, nan_color=NAN_COLOUR)
        # Named for clients that wait for new maps (bench/load_test.py): a veil is sent only when it changes.
        img = ColumnDataSource(dict(image=[np.zeros((2, 2), np.float32)], x=[-1], y=[-1], dw=[2], dh=[2]),
                               name="map-image")
        veil = ColumnDataSource(dict(image=[np.zeros((2, 2), np.float32)], x=[-1], y=[-1], dw=[2], dh=[2]),
                                name="map-veil")
        st = ColumnDataSource(dict(x=[], y=[], name=[]))
        # add_glyph: one glyph model per layer (the plotting API adds a non-selection and a
        # muted copy of each; these maps neither select nor mute)
        fig.add_glyph(img, Image(image="image", x="x", y="y", dw="dw", dh="dh", color_mapper=mapper))
        v = fig.add_glyph(veil, Image(image="image", x="x", y="y", dw="dw", dh="dh", color_mapper=veil_mapper))
        s = fig.add_glyph(st, Scatter(x="x", y="y", marker="triangle", size=13, fill_color="white",
                                      line_color="black", line_width=1.5))
        if which == 0:  # what the shared ranges fit: drawn once, in the first map
            corners.append(fig.add_glyph(view_source, Scatter(x="x", y="y", size=0, line_alpha=0, fill_alpha=0)))
        fmt = CustomJSHover(code=_HOVER_JS, args=dict(img=img, bar=value_bar if which < 2 else diff_bar,
                                                      texts=HoverTexts()))
        # On a station both tooltips show: the map's below the pointer, the station's above it
        # (the station's covered the map's value, issue 46 defect 12).
        hover = HoverTool(renderers=[v], tooltips=[("x", "$x{0.0} m"), ("y", "$y{0.0} m"),
                                                   ("value", "@image{custom}")], attachment="below",
                          formatters={"@image": fmt}, visible=False)  # no toolbar icon: room for save
        save = SaveTool(filename="observability_map")
        fig.add_tools(hover, HoverTool(renderers=[s], tooltips=[("", "@name"), ("x", "@x m"), ("y", "@y m")],
                                       attachment="above", point_policy="follow_mouse", visible=False), save)
        bar = ColorBar(color_mapper=value_bar if which < 2 else diff_bar, title="", orientation="horizontal",
                       height=10, padding=4, margin=8, title_standoff=3, title_text_font_size="11px",
                       title_text_font_style="normal", major_label_text_font_size="11px",
                       formatter=CustomJSTickFormatter(code=_TICK_JS, args=dict(log=False)))
        bar.ticker = BasicTicker(desired_num_ticks=5)
        fig.add_layout(bar, "below")
        # readable: 12 px, near black (they were 7.5 pt grey, 10 px of #555)
        caption = Title(text="", text_font_size=CAPTION_PX, text_color=CAPTION_COLOUR,
                        text_font_style="normal")
        fig.add_layout(caption, "below")
        # Inside the frame: what a map veiled everywhere is (a newcomer took it for broken)
        label = Label(x=4, y=4, x_units="screen", y_units="screen", text="", visible=False,
                      text_font_size=CAPTION_PX, text_color="#222222", background_fill_color="white",
                      background_fill_alpha=0.9, border_line_color="#888888", padding=4)
        fig.add_layout(label)
        for key, model in zip(out, (fig, img, veil, st, bar, hover, fmt, caption, save, label)):
            out[key].append(model)
    for rng in (x_range, y_range):
        rng.renderers = corners
    return MapFigures(view_source=view_source,
                      layout=tuple(out["figs"]), figures=tuple(out["figs"]), images=tuple(out["images"]),
                      veils=tuple(out["veils"]), stations=tuple(out["stations"]),
                      bar_mappers=(value_bar, diff_bar), colorbars=tuple(out["bars"]),
                      hovers=tuple(out["hovers"]), formatters=tuple(out["formatters"]),
                      captions=tuple(out["captions"]), saves=tuple(out["saves"]),
                      labels=tuple(out["labels"]))


def add_previews(figs: MapFigures):
    """Each map's preview layer (app/tabs/maps/live.py), made on the first preview: over the map and under
    its veil (the renderer put right after the map's image), hidden. uint8 levels 0 … PREVIEW_TOP
    of the colour range, PREVIEW_NAN where no value. Its column is ``pv``, not ``image``: what reads
    a map's layers by their ``image`` column (the hover, the tests) sees the exact map and its veil
    only. A no-op when the figures have them."""
    if figs.preview_layers:
        return
    previews, layers = [], []
    for fig in figs.figures:
        pv = ColumnDataSource(dict(pv=[np.zeros((2, 2), np.uint8)], x=[-1], y=[-1], dw=[2], dh=[2]),
                              name="map-preview")
        pv_mapper = LinearColorMapper(palette=Viridis256, low=0, high=PREVIEW_TOP, high_color=NAN_COLOUR)
        layer = GlyphRenderer(data_source=pv, glyph=Image(image="pv", x="x", y="y", dw="dw", dh="dh",
                                                          color_mapper=pv_mapper), visible=False)
        fig.renderers = [fig.renderers[0], layer, *fig.renderers[1:]]
        previews.append(pv)
        layers.append(layer)
    figs.previews, figs.preview_layers = tuple(previews), tuple(layers)


def _changed(model, values):
    """The items of ``values`` that differ from ``model``'s (validating a palette costs time)."""
    return {k: v for k, v in values.items() if getattr(model, k) != v}


def _update_mapper(mapper, values):
    """Set the items of ``values`` that differ on a colour ``mapper``. A new palette (bokeh.palettes'
    own, reversed for the CRLB) is set without Bokeh's property validation (its public
    ``validate(False)``): checking 256 colours took 10–25 ms per mapper, five mappers on every
    change of measure to or from the CRLB, on the event loop."""
    changed = _changed(mapper, values)
    if "palette" in changed:
        with validate(False):
            mapper.update(**changed)
    elif changed:
        mapper.update(**changed)


#: After a map's title while it shows a preview (app/tabs/maps/live.py).
PREVIEW_TITLE = " — preview"


def _prepared(p):
    return p if isinstance(p, Prepared) else prepare(p)


def set_ranges(figs: MapFigures, p):
    """The colour bars' ranges and palettes (the images come normalised to them: module
    docstring). ``p``: Panels or their :func:`prepare`."""
    for bar, (low, high, palette) in zip(figs.bar_mappers, _prepared(p).ranges[1:]):
        _update_mapper(bar, dict(low=low, high=high, palette=palette))


def fill(figs: MapFigures, p):
    """Write one scenario's maps into the figures, in place. ``p``: Panels or their
    :func:`prepare`."""
    d = _prepared(p)
    set_ranges(figs, d)
    set_maps(figs, d)


#: Veil codes drawn transparent (VEIL_PALETTE) and the unobservable stripes' two codes.
_CLEAR_CODES, _STRIPE_CODES = (0, 3, 5), (1, 2)


def uniform_veil(veil):
    """"clear" if the veil ``veil`` shows nothing anywhere, "striped" if it stripes every point
    (unobservable everywhere), else None: what it shows does not depend on its grid."""
    if np.isin(veil, _CLEAR_CODES).all():
        return "clear"
    if np.isin(veil, _STRIPE_CODES).all():
        return "striped"
    return None


def _set_veil(figs, which, veil, where, preview):
    """The veil of map ``which``: ``veil`` over the rectangle ``where``, of a preview or not."""
    old = figs.veils[which].data
    same_rect = all(old[k] == v for k, v in where.items())
    # sent only when it changes; a preview's veil also not when it says what the one shown
    # says everywhere (clear, or striped: :func:`uniform_veil`): the exact veil stays, so
    # the release has nothing to re-send (each release re-sent three 200² veils, 120 kB,
    # after a drag's 100² ones)
    # (the exact veil keeps its rectangle, the exact grid's pixel edges, within a coarse pixel
    # of the preview's: the same plane)
    was = old["image"][0]
    same = same_rect and was.shape == veil.shape and np.array_equal(was, veil)
    if preview and not same:
        du, dv = where["dw"][0] / veil.shape[1], where["dh"][0] / veil.shape[0]
        near = all(abs(old[k][0] - where[k][0]) <= step
                   for k, step in (("x", du), ("dw", du), ("y", dv), ("dh", dv)))
        shows = uniform_veil(veil)
        same = near and shows is not None and shows == uniform_veil(was)
    if not same:
        figs.veils[which].data = dict(image=[veil], **where)


def set_maps(figs: MapFigures, prepared):
    """Everything but the colour bars' ranges: images, veils, stations, titles, labels, tooltips,
    captions (the scenario's parameters, also in a saved PNG), PNG file names. ``prepared``:
    Panels or their :func:`prepare`."""
    d = _prepared(prepared)
    p, maps, (xname, vname) = d.panels, d.maps, d.axes
    where = geometry(p.plane)
    stretch = exaggeration(p.plane)
    vertical = f", vertical ×{stretch:g}" if stretch != 1 else ""
    if d.preview:
        add_previews(figs)
    for which, ((values, observable, stations, title), (low, high, palette)) in enumerate(zip(maps, d.ranges)):
        fig = figs.figures[which]
        layer = figs.preview_layers[which] if figs.preview_layers else None
        if d.preview:
            figs.previews[which].data = dict(pv=[d.images[which]], **where)
            mapper = layer.glyph.color_mapper
        else:
            figs.images[which].data = dict(image=[d.images[which]], **where)
            mapper = fig.renderers[0].glyph.color_mapper
        _update_mapper(mapper, dict(palette=palette))
        if layer is not None and layer.visible != d.preview:
            layer.visible = d.preview
        _set_veil(figs, which, d.veils[which], where, d.preview)
        st = figs.stations[which].data
        if len(st["x"]) != len(stations) or not (np.array_equal(st["x"], stations[:, 0])
                                                 and np.array_equal(st["y"], stations[:, 1])):
            figs.stations[which].data = dict(x=stations[:, 0], y=stations[:, 1],
                                             name=[f"station {i + 1}" for i in range(len(stations))])
        paper = which in p.paper[0]
        fig.title.text = title + (" (paper)" if paper else "") + (PREVIEW_TITLE if d.preview else "")
        fig.title.text_color = "#b03a2e" if paper else "#222222"
        fig.outline_line_color, fig.outline_line_width = ("#b03a2e", 3) if paper else ("#e5e5e5", 1)
        fig.xaxis.axis_label, fig.yaxis.axis_label = f"{xname} (m)", f"{vname} (m)" + vertical
        label = (p.value_labels[which] if p.value_labels else p.value_label) if which < 2 else p.diff_label
        log = which < 2 and p.log_scale
        bar = figs.colorbars[which]
        bar.title = f"{label}, log scale" if log else label
        if bar.formatter.args["log"] != log:
            bar.formatter.args = dict(log=log)
        texts = dict(unobservable=p.unobservable[which] if which < 2 else
                     "undefined: A or B unobservable (rank-deficient)",
                     none="undefined: on a station" if which < 2 else p.blank,
                     runaway=RUNAWAY_TEXT if which < 2 else RUNAWAY_DIFF_TEXT)
        words = figs.formatters[which].args["texts"]  # a new measure or layout: a few strings
        words.update(**_changed(words, dict(texts, log=log)))
        figs.hovers[which].tooltips = [("x", "$x{0.0} m"), (vname, "$y{0.0} m"), (label, "@image{custom}")]
        figs.captions[which].text = wrapped(p.captions[which])
        said = veiled_text(p, which)
        if figs.labels and (figs.labels[which].text, figs.labels[which].visible) != (said, bool(said)):
            figs.labels[which].update(text=said, visible=bool(said))
        figs.saves[which].filename = f"{p.filename}_{'ABD'[which]}"
    view = (p.plane, view_box(p), stretch)
    if figs.view != view and not d.preview:  # a preview's coarser grid keeps the view  # a new plane (or station outside it) resets the view; a new value keeps the zoom
        u0, u1, v0, v1 = view[1]
        figs.view_source.data = dict(x=[u0, u1], y=[min(v0, v1), max(v0, v1)])
        x_range, y_range = _ranges()
        y_range.flipped = p.plane.kind == "xz"  # depth down
        for rng in (x_range, y_range):
            rng.renderers = list(figs.figures[0].x_range.renderers)
        for fig in figs.figures:
            fig.update(x_range=x_range, y_range=y_range, aspect_scale=1.0 / stretch)
        figs.view = view
