"""The Calibration tab's four plots as plain Bokeh figures, built once and updated in place.

HoloViews rebuilt every element of the four plots on each result (9 curves and 9 reference lines
for K alone): ~1-2 s on the server's event loop to render them, and in the browser as long again
to build the new figures, for a 50,000-reading upload (issue 28, bench/bench_calibration_upload.py).
Here :class:`Figures` builds the figures once per session; :func:`plot_data` (a pure function
of the tab's result, run on the worker thread with the computation) gives each data source's new
columns and each figure's title, and :meth:`Figures.show` only assigns them (on the event loop):
the browser receives a few arrays and redraws the existing plots, as the maps do
(app/tabs/maps/figures.py).
"""

from __future__ import annotations

import numpy as np
from bokeh.models import (
    ColorBar,
    ColumnDataSource,
    HoverTool,
    Legend,
    LinearColorMapper,
    Range1d,
)
from bokeh.palettes import RdBu11
from bokeh.plotting import figure

from core import calibration as cal

K_NAMES = cal.COEFFICIENTS[:9]
BP_NAMES = cal.COEFFICIENTS[9:]
#: A colour per coefficient of a convergence plot (Category10 without its grey, which the dashed
#: reference lines use): nine hues at least 27 CIE76 ΔE apart (HoloViews' default cycle gave k11
#: and k33 two blues, k12 and k32 two reds, 15-18 ΔE apart). K's rows also differ in dash.
COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#bcbd22",
           "#17becf")
#: Dash of K's entries by row (sensor axis): k1j solid, k2j dashed, k3j dotted; Bp solid.
ROW_DASH = ("solid", "dashed", "dotted")
#: The three Be components' colours (error plot).
COMPONENT_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c")
COMPONENTS = ("north", "east", "down")
#: Most attitudes a plot draws: a real log has tens of thousands, which the browser need not get
#: (every attitude is in the numbers above; the plots show an even selection and say so).
MAX_PLOT_POINTS = 2000
HEIGHT = 320
#: Axis labels (with units) of the four plots.
LABELS = {"K": ("Iteration n (log scale)", "K entry (dimensionless)"),
          "Bp": ("Iteration n (log scale)", "Bp (nT)"),
          "be": ("Attitude n", "Be error (nT)"),
          "manoeuvre": ("Heading ψ (°)", "Roll θ (°)")}
TITLES = {"K": "Kalman filter: K vs iteration", "Bp": "Kalman filter: Bp vs iteration",
          "be": "Geomagnetic solution error (Kalman K, Bp)", "manoeuvre": "Manoeuvre: attitudes"}


def shown(n):
    """(indices, title note) of the attitudes 0…n−1 a plot draws: all, or MAX_PLOT_POINTS evenly."""
    if n <= MAX_PLOT_POINTS:
        return np.arange(n), ""
    return (np.unique(np.linspace(0, n - 1, MAX_PLOT_POINTS).round().astype(int)),
            f" ({MAX_PLOT_POINTS:,} of {n:,} attitudes shown)")


def _empty_line():
    return {"x": np.zeros(0), "y": np.zeros(0)}


def plot_data(res):
    """Each plot's title and its data sources' new columns for the tab's result ``res``
    (app.tabs.calibration.calibration.compute): {plot: {"title": str, "sources": {name: columns}, ...}}. Empty
    columns where there is nothing to draw (an error, fewer than 4 attitudes)."""
    out = {}
    ok = not res["error"] and res.get("kalman") is not None
    for which, names in (("K", K_NAMES), ("Bp", BP_NAMES)):
        sources = {name: _empty_line() for name in names}
        sources["reference"] = {"xs": [], "ys": []}
        title = TITLES[which]
        if ok:
            h = res["kalman"].coefficients[1:]  # after each step: n = 1…M on a log axis (x(0) = 0)
            cols = slice(0, 9) if which == "K" else slice(9, 12)
            n = np.arange(1, h.shape[0] + 1, dtype=float)
            for j, name in enumerate(names):
                sources[name] = {"x": n, "y": h[:, cols][:, j]}
            truth = res["truth"] is not None
            ref = (np.r_[res["truth"][0].ravel(), res["truth"][1]] if truth
                   else np.r_[res["lsq"].K.ravel(), res["lsq"].Bp])[cols]
            sources["reference"] = {"xs": [[1.0, max(float(n[-1]), 2.0)]] * len(ref),
                                    "ys": [[float(r), float(r)] for r in ref]}
            title += " (dashed: truth)" if truth else " (dashed: least squares)"
        out[which] = {"title": title, "sources": sources}
    sources = {c: _empty_line() for c in COMPONENTS}
    title = TITLES["be"]
    if not res["error"] and res.get("be_err_kal") is not None:
        idx, note = shown(res["be_err_kal"].shape[0])
        e = res["be_err_kal"][idx]
        sources = {c: {"x": (idx + 1).astype(float), "y": e[:, i]} for i, c in enumerate(COMPONENTS)}
        title += note
    out["be"] = {"title": title, "sources": sources}
    att = {"heading": np.zeros(0), "roll": np.zeros(0), "pitch": np.zeros(0), "n": np.zeros(0)}
    title, prange = TITLES["manoeuvre"], (-1.0, 1.0)
    if not res["error"]:
        idx, note = shown(res["attitudes"].shape[0])
        a = np.rad2deg(res["attitudes"][idx])
        att = {"heading": np.mod(a[:, 0], 360), "roll": a[:, 1], "pitch": a[:, 2],
               "n": (idx + 1).astype(float)}
        title += note
        lo, hi = float(a[:, 2].min()), float(a[:, 2].max())
        prange = (lo, hi) if hi > lo else (lo - 1.0, hi + 1.0)  # a constant pitch: a range around it
    out["manoeuvre"] = {"title": title, "sources": {"attitudes": att}, "pitch_range": prange}
    return out


def _figure(which, **kw):
    xlabel, ylabel = LABELS[which]
    fig = figure(title=TITLES[which], height=HEIGHT, sizing_mode="stretch_width",
                 x_axis_label=xlabel, y_axis_label=ylabel, tools="pan,wheel_zoom,box_zoom,reset,save",
                 **kw)
    fig.toolbar.logo = None
    return fig


class Figures:
    """The four plots of one session's tab (Bokeh figures, :attr:`figures` by name: "K", "Bp",
    "be", "manoeuvre") and their data sources."""

    def __init__(self):
        self.figures, self.sources = {}, {}
        for which, names in (("K", K_NAMES), ("Bp", BP_NAMES)):
            fig = _figure(which, x_axis_type="log")
            src = self.sources[which] = {}
            items = []
            for j, name in enumerate(names):
                src[name] = ColumnDataSource(_empty_line(), name=f"cal-{name}")
                r = fig.line("x", "y", source=src[name], color=COLOURS[j], line_width=2,
                             line_dash=ROW_DASH[j // 3] if which == "K" else "solid", name=name)
                items.append((name, [r]))
            src["reference"] = ColumnDataSource({"xs": [], "ys": []})
            fig.multi_line("xs", "ys", source=src["reference"], color="grey", line_dash="dashed",
                           line_width=1)
            fig.add_layout(Legend(items=items, click_policy="hide"), "right")
            fig.add_tools(HoverTool(renderers=[r for _, (r,) in items],
                                    tooltips=[("coefficient", "$name"), ("n", "@x{0}"), ("value", "@y{0.[0000]}")]))
            self.figures[which] = fig
        fig = _figure("be")
        src = self.sources["be"] = {}
        items = []
        for colour, c in zip(COMPONENT_COLOURS, COMPONENTS):
            src[c] = ColumnDataSource(_empty_line(), name=f"cal-be-{c}")
            line = fig.line("x", "y", source=src[c], color=colour, line_width=1.5, name=c)
            dots = fig.scatter("x", "y", source=src[c], color=colour, size=5, name=c)
            items.append((c, [line, dots]))
        fig.add_layout(Legend(items=items, click_policy="hide"), "right")
        fig.add_tools(HoverTool(renderers=[r for _, rs in items for r in rs[1:]],
                                tooltips=[("component", "$name"), ("attitude n", "@x{0}"),
                                          ("error", "@y{0.0} nT")]))
        self.figures["be"] = fig
        fig = _figure("manoeuvre", x_range=Range1d(-10, 370))
        src = self.sources["manoeuvre"] = {"attitudes": ColumnDataSource(
            {"heading": [], "roll": [], "pitch": [], "n": []})}
        self.pitch = LinearColorMapper(palette=tuple(reversed(RdBu11)), low=-1.0, high=1.0)
        r = fig.scatter("heading", "roll", source=src["attitudes"], size=9,
                        fill_color={"field": "pitch", "transform": self.pitch}, line_color="black",
                        line_width=0.5)
        fig.add_layout(ColorBar(color_mapper=self.pitch, title="Pitch φ (°)"), "right")
        fig.add_tools(HoverTool(renderers=[r], tooltips=[
            ("heading ψ", "@heading{0.0}°"), ("roll θ", "@roll{0.00}°"), ("pitch φ", "@pitch{0.00}°"),
            ("attitude n", "@n{0}")]))
        self.figures["manoeuvre"] = fig

    def show(self, data):
        """Assign :func:`plot_data`'s ``data`` (call on the session's event loop, in a hold)."""
        for which, d in data.items():
            self.figures[which].title.text = d["title"]
            for name, cols in d["sources"].items():
                self.sources[which][name].data = cols
        self.pitch.update(low=data["manoeuvre"]["pitch_range"][0],
                          high=data["manoeuvre"]["pitch_range"][1])
