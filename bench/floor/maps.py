"""The visible work of the floor apps (issue 29 item 4), shared by bokeh_app.py and panel_app.py.

Three maps of a 200 × 200 float32 image each, like the dashboard's default view: a colour-mapped
image, a second image layer as a veil (semi-transparent grey where the map is not trusted, NaN
elsewhere), a scatter of the two stations, a colour bar and a hover tool on the image. The
slider's value (P_h) changes the three images; :func:`compute` does ~10 ms of numpy for the three
on one core (elementwise fields of two sources on the grid, N_DECAYS decay lengths each): the
issue's "~10 ms of compute", about the project's in-process compute of the default scenario in
wall time (~12 ms, its kernels on two threads: ~23 ms of CPU; bench_floor reports both apart).
The veil does not depend on P_h (as in the dashboard's whole-space view), so a change replaces
three image arrays.
"""

from __future__ import annotations

import numpy as np
from bokeh.models import ColorBar, ColumnDataSource, HoverTool, LinearColorMapper
from bokeh.palettes import Viridis256
from bokeh.plotting import figure

N = 200
EXTENT = 1000.0  # m, half-width of the square
STATIONS = ((-250.0, 0.0), (250.0, 0.0))
START, END, VALUE, STEP = 10.0, 1000.0, 100.0, 0.1
#: Decay lengths (m) averaged per map, from each map's base length to twice it: their number is
#: the knob that sets the compute to ~10 ms of CPU for the three (two per map, as first written,
#: took 1.4-2.5 ms: the floor did a fifth of the compute the issue asks of it).
N_DECAYS = 16
DECAYS = tuple(tuple(base * 2 ** (k / (N_DECAYS - 1)) for k in range(N_DECAYS)) for base in (200.0, 300.0, 400.0))
LOW, HIGH = -3.0, 6.0

_x = np.linspace(-EXTENT, EXTENT, N)
_X, _Y = np.meshgrid(_x, _x)
_R = [np.hypot(_X - sx, _Y - sy) + 10.0 for sx, sy in STATIONS]
_IR3 = [(r / 100.0) ** -3 for r in _R]


def compute(ph):
    """The three maps (float32, N × N) for slider value ``ph``: log10 of a summed decaying field."""
    out = []
    for decays in DECAYS:
        f = np.zeros((N, N))
        for r, ir3 in zip(_R, _IR3):
            for d in decays:
                f += np.exp(-r / d) * ir3
        out.append(np.log10(ph * f / len(decays)).astype(np.float32))
    return out


def veil():
    """The veil layer: 1 where the farther station is beyond 800 m, NaN (transparent) elsewhere."""
    far = np.maximum(*_R) > 800.0
    return np.where(far, 1.0, np.nan).astype(np.float32)


def image_data(img):
    return dict(image=[img], x=[-EXTENT], y=[-EXTENT], dw=[2 * EXTENT], dh=[2 * EXTENT])


def figures(ph=VALUE):
    """Three figures and their map layers' data sources."""
    figs, sources = [], []
    for k, img in enumerate(compute(ph)):
        p = figure(width=380, height=380, title=f"Map {'ABC'[k]}", x_range=(-EXTENT, EXTENT),
                   y_range=(-EXTENT, EXTENT), tools="pan,wheel_zoom,box_zoom,reset,save",
                   match_aspect=True)
        src = ColumnDataSource(image_data(img))
        mapper = LinearColorMapper(palette=Viridis256, low=LOW, high=HIGH)
        layer = p.image(image="image", x="x", y="y", dw="dw", dh="dh", source=src, color_mapper=mapper)
        p.image(image=[veil()], x=-EXTENT, y=-EXTENT, dw=2 * EXTENT, dh=2 * EXTENT, alpha=0.45,
                color_mapper=LinearColorMapper(palette=["#7f7f7f"], low=0, high=1, nan_color=(0, 0, 0, 0)))
        p.scatter(x=[s[0] for s in STATIONS], y=[s[1] for s in STATIONS], size=12, marker="triangle",
                  fill_color="white", line_color="black")
        p.add_layout(ColorBar(color_mapper=mapper, title="log10"), "right")
        p.add_tools(HoverTool(renderers=[layer], tooltips=[("x", "$x{0}"), ("y", "$y{0}"), ("value", "@image")]))
        figs.append(p)
        sources.append(src)
    return figs, sources


def update(sources, ph):
    """Recompute the three maps and replace their sources' data (the images change in place)."""
    for src, img in zip(sources, compute(ph)):
        src.data = image_data(img)
