"""A study's report (spec §12): one self-contained HTML file, every script inline, no network.

It holds the scenario (every input that differs from its default, with its label and unit; the
format, the project's version, the date), each tab's figures as the page draws them (the app's
own figure and view functions, interactive where the page is), with their captions, the
summary numbers (:func:`study.results.summary`) and every warning and veil the page shows.
"""

from __future__ import annotations

import html
import io
import json

import holoviews as hv
import numpy as np
import panel as pn
from bokeh.layouts import row
from bokeh.core.templates import FILE
from bokeh.resources import INLINE

from app import calibration, map_figures, shape, track, views
from app.calibration_plots import Figures as CalFigures
from app.calibration_plots import plot_data
from app.maps import legend
from app.scenario import defaults, parameter

from .results import scenario_of
from .scenario_file import project_version

hv.extension("bokeh", logo=False)

#: Width of the report's content (px): the maps' row wraps within it.
WIDTH = 1400


def _md(text):
    return pn.pane.Markdown(text, width=WIDTH)


def _table(rows, head):
    cells = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    heads = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    return pn.pane.HTML(f'<table class="study"><thead><tr>{heads}</tr></thead><tbody>{cells}'
                        "</tbody></table>", width=WIDTH)


def scenario_rows(values):
    """(input, label with unit, value, default) of every input that differs from its default."""
    default = defaults()
    return [(n, parameter(n).label, json.dumps(v, ensure_ascii=False) if not isinstance(v, str) else v,
             json.dumps(default[n], ensure_ascii=False) if not isinstance(default[n], str) else default[n])
            for n, v in values.items() if v != default[n]]


def _fmt(x, spec=".3g", unit=""):
    return "—" if x is None else f"{format(x, spec)}{unit}"


def _map_rows(summary):
    rows = []
    for key, m in (summary.get("maps") or {}).items():
        rows.append((f"{key}: {m['title']}", _fmt(100 * m["share_within_threshold"], ".1f", " %"),
                     _fmt(m["median_m"], ".3g", " m"), _fmt(m["p90_m"], ".3g", " m"),
                     _fmt(100 * m["share_unobservable"], ".1f", " %"), m["rank_verdict"]))
    d = summary.get("layout_design")
    if d:
        rows.append(("Layout design: custom stations", _fmt(100 * d["share_within_threshold"], ".1f", " %"),
                     _fmt(d["median_m"], ".3g", " m"), _fmt(d["p90_m"], ".3g", " m"),
                     _fmt(100 * d["share_unobservable"], ".1f", " %"), d["rank_verdict"]))
    return rows


def numbers(summary):
    """The summary numbers as the report's panes."""
    T = summary["threshold_m"]
    out = [_md(f"## The numbers\n\nCRLB position error (1σ, m) over the region; threshold T = {T:g} m "
               "(the Layout design's *CRLB threshold*). Unobservable points count as over T; the "
               "median and the 90th percentile are over the observable points."),
           _table(_map_rows(summary), ("map", "share ≤ T", "median", "90th percentile",
                                       "unobservable", "rank verdict"))]
    sp = summary.get("best_spacing")
    if sp:
        out.append(_md(f"**Best spacing** (dual station): d = {sp['best_d_m']:.1f} m by the "
                       f"{sp['criterion']} ({_fmt(sp['value'])})."))
    tr = summary.get("track")
    if tr:
        flag = "consistent" if tr["nees_consistent"] else "**flagged**: " + tr["nees_flag"]
        out.append(_md(f"**Track** ({tr['filter']}, {tr['runs']} runs): final TRMSE "
                       f"{_fmt(tr['trmse_final_m'])} m against the PCRLB {_fmt(tr['pcrlb_final_m'])} m; "
                       f"mean NEES {_fmt(tr['nees'])}: {flag}"))
    cal = summary.get("calibration") or {}
    if cal.get("coefficients"):
        out.append(_md(f"**Calibration** ({cal['source']}): the coefficients with their CRLB (1σ)."))
        out.append(_table([(r["coefficient"], r["unit"], "yes" if r["observable"] else "no",
                            _fmt(r["kalman"], ".6g"), _fmt(r["least_squares"], ".6g"),
                            _fmt(r["crlb"], ".3g")) for r in cal["coefficients"]],
                          ("coefficient", "unit", "observable", "Kalman", "least squares", "CRLB σ")))
    sh = summary.get("shape")
    if sh:
        out.append(_md(f"**Shape**: {sh['verdict']} (best main-scale σ {_fmt(sh['best_main_scale_sigma_m'])} m "
                       f"against a main scale of {sh['target_main_scale_m']:g} m, closest approach "
                       f"{sh['closest_approach_m']:.3g} m)."))
    return out


def _maps(c):
    figs = map_figures.build()
    map_figures.fill(figs, c.maps)
    for fig in figs.layout:
        fig.sizing_mode = "fixed"
    return [_md("## Maps"), pn.pane.HTML(legend(c.maps), width=WIDTH),
            pn.pane.Bokeh(row(*figs.layout))]


def _design(c):
    out = [_md("## Layout design")]
    if c.design is not None:
        out.append(pn.pane.HoloViews(views.error_map(c.design, "Custom layout: Cramér–Rao error")
                                     * views.station_layer(c.design.stations)))
    if c.spacing is not None:
        out.append(pn.pane.HoloViews(views.spacing_plot(c.spacing)))
    return out


def _track(c):
    if c.track is None:
        return [_md("## Track\n\n" + c.failed.get("Track", ""))]
    return [_md("## Track\n\n" + track.summary_text(c.track)),
            pn.Row(pn.pane.HoloViews(track.plan_view(c.track)),
                   pn.pane.HoloViews(track.error_view(c.track)))]


def _calibration(c):
    res = c.calibration
    if res.get("error"):
        return [_md("## Calibration\n\n" + res["error"])]
    figs = CalFigures()
    figs.show(plot_data(res))
    for fig in figs.figures.values():  # the page stretches them; a file gives them a size
        fig.sizing_mode, fig.width, fig.height = "fixed", 340, fig.height or 300
    return [_md("## Calibration\n\n" + calibration.summary(res)),
            pn.pane.DataFrame(calibration.coefficient_table(res), index=False, width=WIDTH),
            pn.pane.Bokeh(row(*(figs.figures[k] for k in ("K", "Bp", "be", "manoeuvre"))))]


def _shape(c):
    if c.shape is None:
        return [_md("## Shape\n\n" + c.failed.get("Shape", ""))]
    v = shape.views(shape.key_of(scenario_of(c.values)))
    return [_md("## Shape\n\n" + v["verdict"]),
            pn.Row(pn.pane.HoloViews(v["plan"]), pn.pane.HoloViews(v["side"])),
            pn.Row(pn.pane.HoloViews(v["error"]), pn.pane.HoloViews(v["bound"]))]


STYLE = """
table.study { border-collapse: collapse; font-size: 13px; }
table.study td, table.study th { border: 1px solid #bbb; padding: 3px 8px; text-align: left; }
"""


def layout(c, summary, *, title="Observability study", written="", header=None):
    """The report as one Panel layout."""
    header = header or {}
    rows = scenario_rows(c.values)
    head = [_md(f"# {html.escape(title)}\n\nScenario file format {header.get('format', '')} version "
                f"{header.get('version', '')}; project {project_version()}; written {written}."),
            _md("## The scenario\n\nEvery input that differs from its default (the rest are at their "
                "defaults)." if rows else "## The scenario\n\nEvery input at its default."),
            _table(rows, ("input", "label (unit)", "value", "default"))]
    warn = summary["warnings"]
    said = [_md("## Warnings and veils the page shows\n\n" + ("\n".join(f"- {w}" for w in warn)
                                                              if warn else "None."))]
    body = [*head, *numbers(summary), *said, *_maps(c), *_design(c), *_track(c),
            *_calibration(c), *_shape(c)]
    return pn.Column(*body, stylesheets=[STYLE], width=WIDTH + 40)


def write(path, c, summary, **kw):
    """Write the report of results ``c`` and their ``summary`` to ``path`` (str, Path or a text
    file), every resource inline. Bokeh's plain page template: Panel's own links its favicon
    from a CDN, which a browser fetches."""
    page = layout(c, summary, **kw)
    target = path if isinstance(path, io.StringIO) else str(path)
    page.save(target, resources=INLINE, template=FILE, title=kw.get("title", "Observability study"))


#: Most points per axis of a small multiple (the report stays small: 12 variants' maps at full
#: resolution would be several MB).
SMALL_POINTS = 80


def _small(values, plane, vdim, title, clim):
    k = max(1, -(-values.shape[0] // SMALL_POINTS))  # every k-th point: at most SMALL_POINTS
    with np.errstate(divide="ignore", invalid="ignore"):
        logged = np.log10(values[::k, ::k]).astype(np.float32)
    u, v = plane.axes
    img = hv.Image((u[::k], v[::k], logged), kdims=list(views.axes(plane)),
                   vdims=[vdim])
    return img.opts(cmap="viridis_r", clim=clim, colorbar=True, tools=["hover"], title=title,
                    frame_width=220, frame_height=220, clipping_colors={"NaN": "white"})


def comparison_rows(runs, summaries):
    """(variant, numbers…) of each variant: the comparison table."""
    rows = []
    for (variant, _), s in zip(runs, summaries):
        a, b = s["maps"]["A"], s["maps"]["B"]
        tr, sp, sh = s.get("track") or {}, s.get("best_spacing") or {}, s.get("shape") or {}
        rows.append((", ".join(f"{k} = {v}" for k, v in variant.items()) or "as given",
                     _fmt(100 * a["share_within_threshold"], ".1f", " %"), _fmt(a["median_m"], ".3g"),
                     _fmt(100 * b["share_within_threshold"], ".1f", " %"), _fmt(b["median_m"], ".3g"),
                     _fmt(b["p90_m"], ".3g"), _fmt(100 * b["share_unobservable"], ".1f", " %"),
                     _fmt(sp.get("best_d_m"), ".1f"), _fmt(tr.get("trmse_final_m")),
                     _fmt(tr.get("pcrlb_final_m")), "" if tr.get("nees_consistent", True) else "flagged",
                     sh.get("verdict", "")))
    return rows


COMPARISON_HEAD = ("variant", "A: share ≤ T", "A: median (m)", "B: share ≤ T", "B: median (m)",
                   "B: 90th pct (m)", "B: unobservable", "best d (m)", "track TRMSE (m)",
                   "PCRLB (m)", "NEES", "shape")


def write_comparison(path, runs, out, *, title="Observability study: variants", written="",
                     header=None):
    """The comparison report of a batch: the table of every variant's numbers and the CRLB maps
    (A and B, position error, log scale) as small multiples with one colour range."""
    summaries = [s for s, _, _ in out]
    T = summaries[0]["threshold_m"]
    crlbs = [c for _, _, c in out]
    logs = [np.log10(m.value[np.isfinite(m.value) & (m.value > 0)]) for c in crlbs for m in (c.a, c.b)]
    logs = np.concatenate([x for x in logs if x.size]) if any(x.size for x in logs) else np.zeros(1)
    clim = (float(np.percentile(logs, 1)), float(np.percentile(logs, 99)))
    vdim = hv.Dimension("log10_crlb", label="log10 CRLB position error", unit="log10 m")
    tiles = []
    for (variant, _), c in zip(runs, crlbs):
        name = ", ".join(f"{k} = {v}" for k, v in variant.items()) or "as given"
        tiles += [_small(c.a.value, c.plane, vdim, f"A ({name})", clim),
                  _small(c.b.value, c.plane, vdim, f"B ({name})", clim)]
    warn = sorted({w for s in summaries for w in s["warnings"]})
    body = [_md(f"# {html.escape(title)}\n\nProject {project_version()}; written {written}; "
                f"{len(runs)} variants of the scenario (scenario.yaml, its vary block)."),
            _md(f"## The numbers per variant\n\nCRLB position error (1σ, m); threshold T = {T:g} m."),
            _table(comparison_rows(runs, summaries), COMPARISON_HEAD),
            _md("## CRLB position error maps, A and B of each variant (one colour range)"),
            pn.pane.HoloViews(hv.Layout(tiles).cols(4)),
            _md("## Warnings and veils\n\n" + ("\n".join(f"- {w}" for w in warn) if warn else "None."))]
    pn.Column(*body, stylesheets=[STYLE], width=WIDTH + 40).save(
        str(path), resources=INLINE, template=FILE, title=title)
