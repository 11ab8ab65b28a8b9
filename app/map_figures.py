"""The three comparison maps (A, B, difference) as plain Bokeh figures, updated in place.

HoloViews rebuilt every element on each change and sent each map separately (about a second per
slider release, measured by bench/bench_browser.py); here the figures are built once and a change
only replaces the float32 image arrays, colour ranges and titles.

Colour ranges. BokehJS colour-maps an image again on *every* change event of its mapper, twice
(the mapper re-emits ``change`` after rescanning), and with the old image when the range comes
before the data: 17 maps of 200 × 200 per slider change for 3 images. So the images' mappers
never get change events from the server. A change first sends the new ranges alone, to two
mappers that nothing draws (:func:`set_ranges`; no repaint): the browser copies them into the
images' mappers silently (:data:`_COPY_RANGE_JS`). The next patch (:func:`set_maps`) brings the
images, mapped once each with the new range, and the colour bars' own mappers: 3 maps per change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from bokeh.layouts import gridplot
from bokeh.models import (
    ColorBar,
    ColumnDataSource,
    CustomJS,
    HoverTool,
    LinearColorMapper,
    Range1d,
)
from bokeh.palettes import RdBu11, Viridis256
from bokeh.plotting import figure

from .compute import Panels, colour_range

VEIL = "#7f7f7f"
FRAME = 270  # px, each map's plotting area


@dataclass
class MapFigures:
    """Bokeh models of the three maps; :func:`fill` writes a :class:`Panels` into them."""

    layout: object
    figures: tuple
    images: tuple  # ColumnDataSource per map: image, x, y, dw, dh
    veils: tuple
    stations: tuple
    mappers: tuple  # of the images: A and B share mappers[0]; the difference has mappers[1]
    ranges: tuple  # drawn by nothing, same sharing; the browser copies them into mappers
    bar_mappers: tuple  # of the colour bars, same sharing
    colorbars: tuple
    hovers: tuple
    plane: object = None  # the plane last drawn: a new one resets zoom and pan


def _figure(x_range, y_range):
    fig = figure(x_range=x_range, y_range=y_range, frame_width=FRAME, frame_height=FRAME,
                 tools="pan,wheel_zoom,box_zoom,reset,save",
                 match_aspect=False, title="")
    fig.title.text_font_size = "12pt"
    return fig


#: Copies a range carrier into the images' mapper without a change signal (which would colour-map
#: the old images again), and refreshes the scan the mapper caches on such a signal. Without those
#: BokehJS internals (another version), a plain assignment: still correct, one map more.
_COPY_RANGE_JS = """
const range = {low: src.low, high: src.high, palette: src.palette};
if (typeof img.scan === "function" && "_scan_data" in img) {
  img.setv(range, {silent: true});
  img._scan_data = img.scan([], img.palette.length);
} else {
  img.setv(range);
}
"""


def _mappers():
    """(images' mapper, range carrier, colour bar's mapper); the carrier's range is copied into
    the images' mapper in the browser."""
    img, src, bar = (LinearColorMapper(palette=Viridis256, nan_color="white") for _ in range(3))
    copy = CustomJS(args=dict(img=img, src=src), code=_COPY_RANGE_JS)
    for attr in ("low", "high", "palette"):
        src.js_on_change(attr, copy)
    return img, src, bar


def build():
    """Three empty linked maps (one shared x and y range: zoom and pan together)."""
    x_range, y_range = Range1d(-1, 1), Range1d(-1, 1)
    (value_mapper, value_src, value_bar), (diff_mapper, diff_src, diff_bar) = _mappers(), _mappers()
    veil_mapper = LinearColorMapper(palette=["#ffffff00", VEIL], low=0, high=1)
    figs, images, veils, stations, bars, hovers = [], [], [], [], [], []
    for which in range(3):
        fig = _figure(x_range, y_range)
        # Named for clients that wait for new maps (bench/load_test.py): a veil is sent only when it changes.
        img = ColumnDataSource(dict(image=[np.zeros((2, 2), np.float32)], x=[-1], y=[-1], dw=[2], dh=[2]),
                               name="map-image")
        veil = ColumnDataSource(dict(image=[np.zeros((2, 2), np.float32)], x=[-1], y=[-1], dw=[2], dh=[2]),
                                name="map-veil")
        st = ColumnDataSource(dict(x=[], y=[], name=[]))
        mapper, bar_mapper = (value_mapper, value_bar) if which < 2 else (diff_mapper, diff_bar)
        r = fig.image(image="image", x="x", y="y", dw="dw", dh="dh", source=img, color_mapper=mapper)
        fig.image(image="image", x="x", y="y", dw="dw", dh="dh", source=veil, color_mapper=veil_mapper,
                  global_alpha=0.55)
        s = fig.scatter("x", "y", source=st, marker="triangle", size=13, fill_color="white",
                        line_color="black", line_width=1.5)
        hover = HoverTool(renderers=[r], tooltips=[("x", "$x{0.0} m"), ("y", "$y{0.0} m"), ("value", "@image")])
        fig.add_tools(hover, HoverTool(renderers=[s], tooltips=[("", "@name"), ("x", "@x m"), ("y", "@y m")]))
        bar = ColorBar(color_mapper=bar_mapper, title="", width=12, title_text_font_size="9pt")
        fig.add_layout(bar, "right")
        fig.tags = [value_src if which < 2 else diff_src]  # keeps the range carrier in the document
        figs.append(fig), images.append(img), veils.append(veil), stations.append(st)
        bars.append(bar), hovers.append(hover)
    return MapFigures(layout=gridplot([figs], merge_tools=True, toolbar_location="right"), figures=tuple(figs), images=tuple(images), veils=tuple(veils),
                      stations=tuple(stations), mappers=(value_mapper, diff_mapper),
                      ranges=(value_src, diff_src), bar_mappers=(value_bar, diff_bar),
                      colorbars=tuple(bars), hovers=tuple(hovers))


def _symmetric(values):
    finite = values[np.isfinite(values)]
    m = float(np.percentile(np.abs(finite), 99.5)) if finite.size else 1.0
    return (-m or -1.0, m or 1.0)


def _diff_colours(p: Panels):
    """The difference map's colour range, and whether it is the paper's log10(|B| − |A|)
    (sequential palette) rather than the signed log-ratio (diverging, symmetric range)."""
    paper_diff = p.diff_label.startswith("log10(|B|")
    return (colour_range(p.diff) if paper_diff else _symmetric(p.diff)), paper_diff


def _maps(p: Panels):
    """[(values, observable, stations (S, 2), title)] of the three maps, and the axis names."""
    col = 1 if p.plane.kind == "xy" else 2
    maps = []
    for which, res in enumerate((p.a, p.b)):
        title = p.titles[which] + (" — round-off only" if not res.observable.any() else "")
        maps.append((res.value, res.observable, p.stations[which][:, [0, col]], title))
    both = np.unique(np.vstack(p.stations), axis=0)
    maps.append((p.diff, p.a.observable & p.b.observable, both[:, [0, col]], p.titles[2]))
    return maps, ("x", "y" if p.plane.kind == "xy" else "z")


def contents(p: Panels):
    """What each map shows: [(values, observable, stations (S, 2), title)], labels and ranges.

    Pure: the numbers :func:`fill` writes, kept separate so they can be tested without Bokeh.
    """
    maps, axes = _maps(p)
    diff_range, paper_diff = _diff_colours(p)
    return maps, axes, p.clim, diff_range, paper_diff


def _changed(model, values):
    """The items of ``values`` that differ from ``model``'s (validating a palette costs time)."""
    return {k: v for k, v in values.items() if getattr(model, k) != v}


def _set_quietly(model, **values):
    """Set a Python-side Bokeh model's properties without a change event (nothing is sent: the
    browser sets its copy itself). Kept current so that a re-rendered page gets these values."""
    for name, value in values.items():
        model.lookup(name).property.validate(value)
    model._property_values.update(values)


def _ranges(p: Panels):
    diff_range, paper_diff = _diff_colours(p)
    return (dict(low=p.clim[0], high=p.clim[1], palette=Viridis256),
            dict(low=diff_range[0], high=diff_range[1], palette=Viridis256 if paper_diff else RdBu11[::-1]))


def set_ranges(figs: MapFigures, p: Panels):
    """The colour ranges, to the carriers (sent; nothing redrawn) and the images' mappers (set in
    the browser from the carriers; see the module docstring). Send before :func:`set_maps`, in a
    patch of its own."""
    for img, src, values in zip(figs.mappers, figs.ranges, _ranges(p)):
        src.update(**_changed(src, values))
        _set_quietly(img, **_changed(img, values))


def fill(figs: MapFigures, p: Panels):
    """Write one scenario's maps into the figures, in place (ranges and maps in one go).
    :func:`set_maps` alone draws the ranges last given to :func:`set_ranges`."""
    set_ranges(figs, p)
    set_maps(figs, p)


def set_maps(figs: MapFigures, p: Panels):
    """Everything but the images' colour ranges: images, veils, stations, titles, labels,
    tooltips, colour bars."""
    maps, (xname, vname) = _maps(p)
    for bar, src in zip(figs.bar_mappers, figs.ranges):  # as set_ranges set them
        bar.update(**_changed(bar, dict(low=src.low, high=src.high, palette=src.palette)))
    (u0, u1), (v0, v1) = p.plane.u, p.plane.v
    du, dv = (u1 - u0) / (p.plane.n - 1), (v1 - v0) / (p.plane.n - 1)
    geometry = dict(x=[u0 - du / 2], y=[v0 - dv / 2], dw=[u1 - u0 + du], dh=[v1 - v0 + dv])
    for which, (values, observable, stations, title) in enumerate(maps):
        fig = figs.figures[which]
        figs.images[which].data = dict(image=[values.astype(np.float32)], **geometry)
        veil = (~observable).astype(np.float32)
        old = figs.veils[which].data["image"][0]
        if old.shape != veil.shape or not np.array_equal(old, veil) or figs.veils[which].data["x"] != geometry["x"]:
            figs.veils[which].data = dict(image=[veil], **geometry)  # sent only when it changes
        st = figs.stations[which].data
        if len(st["x"]) != len(stations) or not (np.array_equal(st["x"], stations[:, 0])
                                                 and np.array_equal(st["y"], stations[:, 1])):
            figs.stations[which].data = dict(x=stations[:, 0], y=stations[:, 1],
                                             name=[f"station {i + 1}" for i in range(len(stations))])
        fig.title.text = title
        fig.xaxis.axis_label, fig.yaxis.axis_label = f"{xname} (m)", f"{vname} (m)"
        label = p.value_label if which < 2 else p.diff_label
        unit = f" {p.value_unit}" if which < 2 and p.value_unit == "m" else ""
        figs.colorbars[which].title = label
        figs.hovers[which].tooltips = [("x", "$x{0.0} m"), (vname, "$y{0.0} m"), (label, "@image{0.000}" + unit)]
    if figs.plane != p.plane:  # a new plane resets the view; a new value keeps the zoom
        figs.figures[0].x_range.update(start=u0 - du / 2, end=u1 + du / 2)
        figs.figures[0].y_range.update(start=v0 - dv / 2, end=v1 + dv / 2)
        figs.plane = p.plane
