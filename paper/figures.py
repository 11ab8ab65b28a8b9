"""The paper's Figs. 1–6 (and three extra figures) as panels, rendered to PNG and HTML.

A :class:`Panel` is pure data (a map over a :class:`core.Plane` plus what is unobservable in it);
:func:`render_png` draws one panel with matplotlib (Agg) and :func:`render_html` a whole figure
with Bokeh. Single-station panels carry ``roundoff=True``: they are hatched and their titles say
that the values are float64 round-off of a structurally singular Γ (spec §4).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

import core

from . import scenarios as sc

#: PNG size in inches; pixels = FIGSIZE × dpi (no tight bounding box, so the size is exact).
FIGSIZE = (5.6, 4.4)
ROUNDOFF_NOTE = "ROUND-OFF, not observability: one station is rank 6, det Γ = 0"
DET_LABEL = "log10 |det Γ| (float64; paper's log is log10)"
POS_LABEL = "log10(|det Γ_A| − |det Γ_B|); blank where ≤ 0"
RATIO_LABEL = "log10 |det Γ_A| − log10 |det Γ_B| (decades)"
DOPT_LABEL = "D-optimal ½·log10 det F (7 states)"


@dataclass
class Panel:
    key: str
    title: str
    plane: core.Plane
    values: np.ndarray
    label: str
    unobservable: np.ndarray
    roundoff: bool = False
    diverging: bool = False


@dataclass
class Figure:
    key: str
    title: str
    panels: list = field(default_factory=list)
    line: dict | None = None  # for the d-scan figure: {"x":…, "series": {name: ys}, …}


def _det(plane, model, d=None, moments=(sc.PH, sc.PV)):
    r = sc.field_map(plane, d, tuple(moments), "log10_det", model)
    return r.value, ~r.observable & ~np.isnan(r.value)


def _pair(key, title, plane, a, b, roundoff):
    """The paper's positive-difference panel and the signed log-ratio beside it."""
    (va, ua), (vb, ub) = a, b
    un = ua | ub
    return [
        Panel(f"{key}_diff", f"{title}: log10 Δ|det Γ|", plane,
              core.log10_positive_difference(va, vb), POS_LABEL, un, roundoff),
        Panel(f"{key}_ratio", f"{title}: log-ratio", plane,
              core.log10_ratio(va, vb), RATIO_LABEL, un, roundoff, diverging=True),
    ]


def paper_figures(model, n):
    """Figs. 1–6 of the paper for one field model on n × n grids (spec §5 presets)."""
    xy, xz = sc.xy_plane(n), sc.xz_plane(n)
    m = f"[{model}]"
    figs = []
    v, u = _det(xy, model)
    figs.append(Figure("fig1", f"Fig. 1 {m}: log10|det Γ| over x, y, one station, z = 120 m",
                       [Panel("fig1a", "Fig. 1: log10|det Γ|, one station", xy, v, DET_LABEL, u, True)]))
    f2 = Figure("fig2", f"Fig. 2 {m}: log10|det Γ| over x, z at y = 50 m, one station")
    for letter, mom in (("a", (sc.PH, sc.PV)), ("b", (100.0, 100.0))):
        v, u = _det(xz, model, moments=mom)
        f2.panels.append(Panel(f"fig2{letter}", f"Fig. 2({letter}): Ph, Pv = {mom[0]:g}, {mom[1]:g} A·m",
                               xz, v, DET_LABEL, u, True))
    figs.append(f2)
    figs.append(Figure("fig3", f"Fig. 3 {m}: moments ×10 minus original, one station", _pair(
        "fig3", "Fig. 3: ×10 − original", xy, _det(xy, model, moments=(10 * sc.PH, 10 * sc.PV)),
        _det(xy, model), True)))
    f4 = Figure("fig4", f"Fig. 4 {m}: (Ph, Pv) redistributed, more vertical minus more horizontal, one station")
    for letter, (ib, ia) in zip("abc", sc.FIG4_PAIRS):
        mb, ma = sc.FIG4_MOMENTS[ib], sc.FIG4_MOMENTS[ia]
        f4.panels += _pair(f"fig4{letter}", f"Fig. 4({letter}): ({mb[0]:g}, {mb[1]:g}) − ({ma[0]:g}, {ma[1]:g})",
                           xy, _det(xy, model, moments=mb), _det(xy, model, moments=ma), True)
    figs.append(f4)
    f5 = Figure("fig5", f"Fig. 5 {m}: dual minus single station")
    for letter, d in zip("ab", sc.FIG5_D):
        f5.panels += _pair(f"fig5{letter}", f"Fig. 5({letter}): dual d = {d:g} m − single", xy,
                           _det(xy, model, d), _det(xy, model), True)
    figs.append(f5)
    f6 = Figure("fig6", f"Fig. 6 {m}: dual with d minus dual with d = {sc.FIG6_BASE:g} m")
    for letter, d in zip("abc", sc.FIG6_D):
        f6.panels += _pair(f"fig6{letter}", f"Fig. 6({letter}): d = {d:g} m − d = {sc.FIG6_BASE:g} m", xy,
                           _det(xy, model, d), _det(xy, model, sc.FIG6_BASE), False)
    figs.append(f6)
    return figs


def extra_figures(model, n, scan):
    """Round-off index maps, the moments-known single station, and the d scan."""
    xy = sc.xy_plane(n)
    figs = []
    single = sc.field_map(xy, None, (sc.PH, sc.PV), "log10_eta", model)
    dual = sc.field_map(xy, sc.DUAL_D, (sc.PH, sc.PV), "log10_eta", model)
    figs.append(Figure("eta", f"Observability index log10 η = log10(|det Γ| / Π‖Γ_j‖) [{model}]; "
                       "grey: rank < 7", [
                           Panel("eta_single", "log10 η, one station (Fig. 1 scenario)", xy, single.value,
                                 "log10 η (dimensionless)", ~single.observable, True),
                           Panel("eta_dual", f"log10 η, dual d = {sc.DUAL_D:g} m", xy, dual.value,
                                 "log10 η (dimensionless)", ~dual.observable & ~np.isnan(dual.value))]))
    dopt = sc.field_map(xy, None, (sc.PH, sc.PV), "d_optimal", model, sc.KNOWN)
    crlb = sc.field_map(xy, None, (sc.PH, sc.PV), "crlb_position", model, sc.KNOWN)
    with np.errstate(divide="ignore"):
        lcrlb = np.log10(crlb.value)
    figs.append(Figure("known", f"One station, moments known (5 states) [{model}]", [
        Panel("known_dopt", "One station, moments known: D-optimal", xy, dopt.value,
              "½·log10 det F (5 states)", ~dopt.observable),
        Panel("known_crlb", "One station, moments known: CRLB position", xy, lcrlb,
              "log10 CRLB position error (m)", ~crlb.observable)]))
    s = scan[model]
    figs.append(Figure("dscan", f"Dual-station spacing scan over Fig. 5's region [{model}]", line={
        "x": scan["d_m"], "xlabel": "station spacing d (m)",
        "panels": [
            ("mean D-optimal ½·log10 det F", {"7 states, map mean": s["d_optimal"]["mean"],
                                              "5 states (moments known), map mean": s["d_optimal_known"]["mean"],
                                              "7 states, within 50 m of station 1": s["d_optimal"]["near_mean"]}),
            ("median CRLB position error (m)", {"7 states": s["crlb_median"]}),
        ]}))
    return figs


# --------------------------------------------------------------------------------------------
# Rendering


def _limits(panel):
    v = panel.values[np.isfinite(panel.values)]
    if v.size == 0:
        return -1.0, 1.0
    if panel.diverging:
        top = float(np.max(np.abs(v))) or 1.0
        return -top, top
    lo, hi = float(v.min()), float(v.max())
    return (lo, hi) if hi > lo else (lo - 1.0, hi + 1.0)


def render_png(panel, path, dpi):
    """One panel to ``path`` (PNG of FIGSIZE × dpi pixels)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Rectangle

    u, v = panel.plane.axes
    extent = (u[0], u[-1], v[0], v[-1])
    fig = plt.figure(figsize=FIGSIZE, dpi=dpi)
    # fixed axes rather than a layout engine: half the drawing time, and the same size every time
    ax, cax = fig.add_axes((0.13, 0.11, 0.62, 0.76)), fig.add_axes((0.78, 0.11, 0.03, 0.76))
    try:
        cmap = plt.get_cmap("RdBu_r" if panel.diverging else "viridis").with_extremes(bad="white")
        lo, hi = _limits(panel)
        im = ax.imshow(np.ma.masked_invalid(panel.values), origin="lower", extent=extent, aspect="auto",
                       cmap=cmap, vmin=lo, vmax=hi, interpolation="nearest")
        fig.colorbar(im, cax=cax, label=panel.label)
        if panel.roundoff:
            ax.add_patch(Rectangle((u[0], v[0]), u[-1] - u[0], v[-1] - v[0], fill=False, hatch="//",
                                   edgecolor="0.35", linewidth=0))
            ax.text(0.5, 0.04, ROUNDOFF_NOTE, transform=ax.transAxes, ha="center", fontsize=7,
                    color="darkred", bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "darkred"})
        elif panel.unobservable.any():
            ax.imshow(np.where(panel.unobservable, 1.0, np.nan), origin="lower", extent=extent,
                      aspect="auto", cmap=ListedColormap(["0.3"]), alpha=0.6, interpolation="nearest")
        ax.set_xlabel(f"{panel.plane.labels[0]} (m)")
        ax.set_ylabel(f"{panel.plane.labels[1]} (m)")
        ax.set_title(panel.title + ("\n[" + "structurally singular: values are round-off" + "]"
                                    if panel.roundoff else ""), fontsize=9,
                     color="darkred" if panel.roundoff else "black")
        fig.savefig(path, dpi=dpi)
    finally:
        plt.close(fig)


def render_line_png(figure, path, dpi):
    """The d-scan curves to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    line = figure.line
    fig, axes = plt.subplots(1, len(line["panels"]), figsize=(FIGSIZE[0] * 1.6, FIGSIZE[1]), dpi=dpi,
                             layout="constrained")
    try:
        for ax, (ylabel, series) in zip(axes, line["panels"]):
            for name, ys in series.items():
                ax.plot(line["x"], ys, marker=".", label=name)
                best = int(np.nanargmin(ys) if "CRLB" in ylabel else np.nanargmax(ys))
                ax.plot(line["x"][best], ys[best], "k*", markersize=9)
            ax.set_xscale("log")
            ax.set_xlabel(line["xlabel"])
            ax.set_ylabel(ylabel)
            if "CRLB" in ylabel:
                ax.set_yscale("log")
            ax.legend(fontsize=7)
            ax.grid(alpha=0.3)
        fig.suptitle(figure.title + " (★ = best)", fontsize=9)
        fig.savefig(path, dpi=dpi)
    finally:
        plt.close(fig)


def _bokeh_panel(panel):
    from bokeh.models import ColorBar, HoverTool, Label, LinearColorMapper
    from bokeh.palettes import RdBu11, Viridis256
    from bokeh.plotting import figure

    u, v = panel.plane.axes
    lo, hi = _limits(panel)
    mapper = LinearColorMapper(palette=tuple(reversed(RdBu11)) if panel.diverging else Viridis256,
                               low=lo, high=hi, nan_color="white")
    p = figure(title=panel.title + (" — " + ROUNDOFF_NOTE if panel.roundoff else ""),
               x_range=(u[0], u[-1]), y_range=(v[0], v[-1]), width=520, height=420,
               x_axis_label=f"{panel.plane.labels[0]} (m)", y_axis_label=f"{panel.plane.labels[1]} (m)")
    img = p.image(image=[np.asarray(panel.values)], x=u[0], y=v[0], dw=u[-1] - u[0], dh=v[-1] - v[0],
                  color_mapper=mapper)
    p.add_tools(HoverTool(renderers=[img], tooltips=[(f"{panel.plane.labels[0]} (m)", "$x{0.0}"),
                                                     (f"{panel.plane.labels[1]} (m)", "$y{0.0}"),
                                                     ("value", "@image{0.000}")]))
    p.add_layout(ColorBar(color_mapper=mapper, title=panel.label), "right")
    if panel.roundoff:
        p.quad(left=u[0], right=u[-1], bottom=v[0], top=v[-1], fill_alpha=0, line_alpha=0,
               hatch_pattern="/", hatch_color="#444444", hatch_alpha=0.5)
        p.add_layout(Label(x=10, y=10, x_units="screen", y_units="screen", text=ROUNDOFF_NOTE,
                           text_color="darkred", text_font_size="9pt", background_fill_color="white",
                           background_fill_alpha=0.85))
        p.title.text_color = "darkred"
    elif panel.unobservable.any():
        grey = LinearColorMapper(palette=["#444444"], low=0, high=2, nan_color=(0, 0, 0, 0))
        p.image(image=[np.where(panel.unobservable, 1.0, np.nan)], x=u[0], y=v[0], dw=u[-1] - u[0],
                dh=v[-1] - v[0], color_mapper=grey, global_alpha=0.6)
    return p


def _bokeh_line(figure_):
    from bokeh.palettes import Category10
    from bokeh.plotting import figure

    line = figure_.line
    plots = []
    for ylabel, series in line["panels"]:
        crlb = "CRLB" in ylabel
        p = figure(title=figure_.title, width=560, height=420, x_axis_type="log",
                   y_axis_type="log" if crlb else "linear", x_axis_label=line["xlabel"], y_axis_label=ylabel,
                   tooltips=[("d (m)", "$x{0.0}"), ("value", "$y{0.000}")])
        for (name, ys), colour in zip(series.items(), Category10[10]):
            p.line(line["x"], ys, legend_label=name, color=colour)
            p.scatter(line["x"], ys, color=colour, size=4)
        p.legend.label_text_font_size = "8pt"
        plots.append(p)
    return plots


def render_html(figure_, path, inline=False):
    """A whole figure (all panels, interactive) to a standalone HTML file."""
    from bokeh.io import save
    from bokeh.layouts import gridplot
    from bokeh.resources import CDN, INLINE

    plots = _bokeh_line(figure_) if figure_.line else [_bokeh_panel(p) for p in figure_.panels]
    layout = gridplot(plots, ncols=2)
    save(layout, filename=str(path), resources=INLINE if inline else CDN, title=figure_.title)
