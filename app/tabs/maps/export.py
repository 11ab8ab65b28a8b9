"""A high-resolution PNG of the three maps, drawn by matplotlib from the arrays the page draws.

The save tool of a Bokeh map writes its canvas as shown: ~400 × 450 px at a 1600 px screen, too
coarse for a report (issue 25). Bokeh's own ``export_png`` needs a browser and a webdriver on the
server; here the same numbers (:func:`app.tabs.maps.data.prepare`: values, colour ranges and palettes,
veil codes, stations, titles, axis labels, captions) are drawn again with matplotlib's Agg canvas
(no browser, no pyplot state: safe on a worker thread), at :data:`WIDTH_PX` pixels across.
"""

from __future__ import annotations

import io

import numpy as np

from . import data as map_data

#: Pixels across the exported PNG (three maps side by side: ~900 px each).
WIDTH_PX = 2700
#: Pixels across the PNG of one map (the Download card's A, B and difference buttons; the save
#: tool of a map on the page writes its canvas as shown, ~200-400 px).
MAP_WIDTH_PX = 1200
DPI = 200
#: The maps of :func:`figure`: A, B and their difference.
ALL = (0, 1, 2)


def _rgba(hex_colour):
    h = hex_colour.lstrip("#")
    alpha = int(h[6:8], 16) / 255 if len(h) == 8 else 1.0
    return tuple(int(h[k:k + 2], 16) / 255 for k in (0, 2, 4)) + (alpha,)


def _tick_formatter(log):
    """The colour bar's tick labels as the page writes them (map_data.tick_texts: one notation
    for all the ticks of a bar, so the formatter sees them all)."""
    from matplotlib.ticker import Formatter

    class Ticks(Formatter):
        ticks = ()

        def set_locs(self, locs):  # the bar's ticks, given before their labels are asked for
            self.ticks = list(locs)

        def __call__(self, x, pos=None):
            if pos is not None and pos < len(self.ticks) and self.ticks[pos] == x:
                return map_data.tick_texts(self.ticks, log)[pos]
            return map_data.tick_texts([x], log)[0]  # a value on its own

    return Ticks()


def figure(p, which=ALL):
    """A matplotlib Figure of the maps of ``p`` (Panels, or their :func:`map_data.prepare`):
    those of ``which`` (indices: 0 A, 1 B, 2 the difference), side by side."""
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure

    d = p if isinstance(p, map_data.Prepared) else map_data.prepare(p)
    panels = d.panels
    where = map_data.geometry(panels.plane)
    x0, y0 = where["x"][0], where["y"][0]
    extent = (x0, x0 + where["dw"][0], y0, y0 + where["dh"][0])
    stretch = map_data.exaggeration(panels.plane)
    xname, vname = d.axes
    u0, u1, v0, v1 = map_data.view_box(panels)
    veil_colours = np.array([_rgba(c) for c in map_data.VEIL_PALETTE])
    which = tuple(which)
    if len(which) == 3:
        size = (WIDTH_PX / DPI, 0.5 * WIDTH_PX / DPI)
    else:  # each map about as tall for its width as in the three (its bar and caption below it)
        size = (MAP_WIDTH_PX * len(which) / DPI, 1.4 * MAP_WIDTH_PX / DPI)
    fig = Figure(figsize=size, dpi=DPI, facecolor="white")
    axes = np.atleast_1d(fig.subplots(1, len(which)))
    for ax, which in zip(axes, which):
        (values, _obs, stations, title), (low, high, palette) = d.maps[which], d.ranges[which]
        cmap = ListedColormap(list(palette)).with_extremes(bad="white")
        shown = np.ma.masked_invalid(np.asarray(values, dtype=float))
        img = ax.imshow(shown, origin="lower", extent=extent, cmap=cmap, vmin=low, vmax=high,
                        interpolation="nearest", aspect=stretch)
        codes = d.veils[which].astype(int)
        ax.imshow(veil_colours[codes], origin="lower", extent=extent, interpolation="nearest",
                  aspect=stretch)
        ax.scatter(stations[:, 0], stations[:, 1], marker="^", s=60, facecolor="white",
                   edgecolor="black", linewidth=1.2, zorder=3)
        ax.set_xlim(min(u0, u1), max(u0, u1))
        ax.set_ylim(v0, v1)  # x–z: (deep, shallow): depth down
        paper = which in panels.paper[0]
        ax.set_title(title + (" (paper)" if paper else ""), fontsize=9, fontweight="bold",
                     color="#b03a2e" if paper else "#222222")
        if paper:
            for spine in ax.spines.values():
                spine.set(color="#b03a2e", linewidth=2.5)
        ax.set_xlabel(f"{xname} (m)", fontsize=8)
        ax.set_ylabel(f"{vname} (m)" + (f", vertical ×{stretch:g}" if stretch != 1 else ""), fontsize=8)
        ax.tick_params(labelsize=7)
        label = ((panels.value_labels[which] if panels.value_labels else panels.value_label)
                 if which < 2 else panels.diff_label)
        log = which < 2 and panels.log_scale
        bar = fig.colorbar(img, ax=ax, orientation="horizontal", fraction=0.05, pad=0.16,
                           format=_tick_formatter(log))
        bar.set_label(f"{label}, log scale" if log else label, fontsize=7)
        bar.ax.tick_params(labelsize=6.5)
        bar.ax.annotate(map_data.wrapped(panels.captions[which], 70), xy=(0, 0), xycoords="axes fraction",
                        xytext=(0, -30), textcoords="offset points", fontsize=6, color="#555555",
                        va="top", ha="left")  # under the colour bar's label
        said = map_data.veiled_text(panels, which)
        if said:
            ax.text(0.03, 0.03, said, transform=ax.transAxes, fontsize=6.5, va="bottom", ha="left",
                    bbox=dict(facecolor="white", alpha=0.9, edgecolor="#888888"))
    if len(axes) == 3:
        fig.subplots_adjust(left=0.05, right=0.99, top=0.93, bottom=0.24, wspace=0.28)
    else:
        fig.subplots_adjust(left=0.14, right=0.96, top=0.93, bottom=0.26, wspace=0.28)
    return fig


def to_png(p, which=ALL) -> io.BytesIO:
    """PNG bytes of :func:`figure` (WIDTH_PX wide; one map: MAP_WIDTH_PX)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = figure(p, which)
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, facecolor="white")
    buf.seek(0)
    return buf
