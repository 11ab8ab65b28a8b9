"""A study's report (spec §12): one self-contained HTML file, every script inline, no network.

Written with Bokeh alone (``bokeh.embed.file_html`` with INLINE resources): the page's Bokeh
figures as they are, its HoloViews views rendered by HoloViews' Bokeh renderer, texts as Bokeh
``Div``s. Not with Panel's ``save``: its panes link Panel's stylesheets from its CDN even with
inline resources (holoviz/panel#6759, open), and a report must open with no network.

It holds the scenario (every input that differs from its default, with its label and unit; the
format, the project's version, the date), each tab's figures as the page draws them (the app's
own figure and view functions, interactive where the page is), with their captions, the
summary numbers (:func:`app.report.results.summary`) and every warning and veil the page shows.
"""

from __future__ import annotations

import html
import json
import warnings
from pathlib import Path

import holoviews as hv
import markdown
import numpy as np
from bokeh.core.validation import silence
from bokeh.core.validation.warnings import FIXED_SIZING_MODE
from bokeh.embed import file_html
from bokeh.layouts import column, row
from bokeh.models import Div, InlineStyleSheet
from bokeh.resources import Resources

from ..kit import views
from ..state.scenario import defaults, parameter
from ..state.scenario_file import project_version
from ..tabs.calibration import calibration
from ..tabs.calibration.plots import Figures as CalFigures
from ..tabs.calibration.plots import plot_data
from ..tabs.maps import figures as map_figures
from ..tabs.maps.maps import legend
from ..tabs.shape import shape
from ..tabs.track import track
from .results import scenario_of

hv.extension("bokeh", logo=False)

#: Width of the report's content (px): the maps' row wraps within it.
WIDTH = 1400


STYLE = """
table { border-collapse: collapse; font-size: 13px; }
td, th { border: 1px solid #bbb; padding: 3px 8px; text-align: left; }
div { font-family: sans-serif; font-size: 14px; color: #222; }
"""


def _div(text_html):
    return Div(text=text_html, width=WIDTH, stylesheets=[InlineStyleSheet(css=STYLE)])


def _md(text):
    return _div(markdown.markdown(text, extensions=["tables"]))


def _table(rows, head):
    cells = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>" for r in rows)
    heads = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    return _div(f"<table><thead><tr>{heads}</tr></thead><tbody>{cells}</tbody></table>")


def _plot(view):
    """A HoloViews view of the page, as Bokeh (HoloViews' own renderer)."""
    return hv.render(view, backend="bokeh")


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
    return [_md("## Maps"), _div(legend(c.maps)), row(*figs.layout)]


def _design(c):
    out = [_md("## Layout design")]
    if c.design is not None:
        out.append(_plot(views.error_map(c.design, "Custom layout: Cramér–Rao error")
                         * views.station_layer(c.design.stations)))
    if c.spacing is not None:
        out.append(_plot(views.spacing_plot(c.spacing)))
    return out


def _track(c):
    if c.track is None:
        return [_md("## Track\n\n" + c.failed.get("Track", ""))]
    return [_md("## Track\n\n" + track.summary_text(c.track)),
            row(_fixed(_plot(track.plan_view(c.track))), _fixed(_plot(track.error_view(c.track))))]


def _calibration(c):
    res = c.calibration
    if res.get("error"):
        return [_md("## Calibration\n\n" + res["error"])]
    figs = CalFigures()
    figs.show(plot_data(res))
    for fig in figs.figures.values():  # the page stretches them; a file gives them a size
        fig.sizing_mode, fig.width, fig.height = "fixed", 340, fig.height or 300
    return [_md("## Calibration\n\n" + calibration.summary(res)),
            _div(calibration.coefficient_table(res).to_html(index=False, border=0)),
            row(*(figs.figures[k] for k in ("K", "Bp", "be", "manoeuvre")))]


def _shape(c):
    if c.shape is None:
        return [_md("## Shape\n\n" + c.failed.get("Shape", ""))]
    v = shape.views(shape.key_of(scenario_of(c.values)))
    return [_md("## Shape\n\n" + v["verdict"]),
            row(_fixed(_plot(v["plan"])), _fixed(_plot(v["side"]))),
            row(_fixed(_plot(v["error"])), _fixed(_plot(v["bound"])))]


def _fixed(fig, width=WIDTH // 2 - 20, height=420):
    """A figure the page stretches to its column, at a size of its own in the report."""
    if fig.sizing_mode not in (None, "fixed"):
        fig.sizing_mode, fig.width, fig.height = "fixed", width, fig.height or height
    return fig


def layout(c, summary, *, title="Observability study", written="", header=None):
    """The report as one Bokeh layout."""
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
    return column(*body)


class Inline(Resources):
    """Bokeh's own scripts and styles, inline, and nothing to fetch: Bokeh adds the scripts and
    styles every imported model class names (``__javascript__``, ``__css__``: for Panel's, a
    relative ``static/…`` path) as links, which a file opened alone cannot load."""

    def __init__(self, components=None):
        super().__init__(mode="inline", components=components)

    def clone(self, *, components=None):
        # Bokeh clones the resources without the parts the report does not use (tables, GL …)
        return Inline(self.components if components is None else components)

    @property
    def js_files(self):
        return []

    @property
    def css_files(self):
        return []


def html_of(page, title):
    """The self-contained HTML text of a Bokeh layout."""
    # HoloViews sizes its fixed plots by their frame (frame_width), not width and height, which
    # Bokeh's check of a fixed figure would warn about, once per plot
    silence(FIXED_SIZING_MODE, True)
    try:
        return file_html(page, Inline(), title)
    finally:
        silence(FIXED_SIZING_MODE, False)


def write(path, c, summary, **kw):
    """Write the report of results ``c`` and their ``summary`` to ``path``, every resource
    inline."""
    text = html_of(layout(c, summary, **kw), kw.get("title", "Observability study"))
    Path(path).write_text(text, encoding="utf-8")


#: Most points per axis of a small multiple (the report stays small: 12 variants' maps at full
#: resolution would be several MB).
SMALL_POINTS = 80


def _small(result, plane, vdim, title, clim):
    """One small multiple: a CRLB map (core.MapResult) in log10 m, unobservable points blank."""
    k = max(1, -(-result.value.shape[0] // SMALL_POINTS))  # every k-th point: at most SMALL_POINTS
    values = np.where(result.observable, result.value, np.nan)[::k, ::k]
    with np.errstate(divide="ignore", invalid="ignore"):
        logged = np.log10(values).astype(np.float32)
    u, v = plane.axes
    img = hv.Image((u[::k], v[::k], logged), kdims=list(views.axes(plane)),
                   vdims=[vdim])
    return img.opts(cmap="viridis_r", clim=clim, colorbar=True, tools=["hover"], title=title,
                    frame_width=220, frame_height=220, clipping_colors={"NaN": "white"})


def _tiles(tiles):
    """The small multiples as Bokeh. A map unobservable everywhere is all blank (NaN): HoloViews
    asks numpy for its range, which warns of an all-NaN slice; the colour range is given."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "All-NaN slice encountered", RuntimeWarning)
        return _plot(hv.Layout(tiles).cols(4))


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
    logs = [np.log10(m.value[m.observable & np.isfinite(m.value) & (m.value > 0)])
            for c in crlbs for m in (c.a, c.b)]
    logs = np.concatenate([x for x in logs if x.size]) if any(x.size for x in logs) else np.zeros(1)
    clim = (float(np.percentile(logs, 1)), float(np.percentile(logs, 99)))
    vdim = hv.Dimension("log10_crlb", label="log10 CRLB position error", unit="log10 m")
    tiles = []
    for (variant, _), c in zip(runs, crlbs):
        name = ", ".join(f"{k} = {v}" for k, v in variant.items()) or "as given"
        tiles += [_small(c.a, c.plane, vdim, f"A ({name})", clim),
                  _small(c.b, c.plane, vdim, f"B ({name})", clim)]
    warn = sorted({w for s in summaries for w in s["warnings"]})
    body = [_md(f"# {html.escape(title)}\n\nProject {project_version()}; written {written}; "
                f"{len(runs)} variants of the scenario (scenario.yaml, its vary block)."),
            _md(f"## The numbers per variant\n\nCRLB position error (1σ, m); threshold T = {T:g} m."),
            _table(comparison_rows(runs, summaries), COMPARISON_HEAD),
            _md("## CRLB position error maps, A and B of each variant (one colour range; "
                "unobservable points blank)"),
            _tiles(tiles),
            _md("## Warnings and veils\n\n" + ("\n".join(f"- {w}" for w in warn) if warn else "None."))]
    Path(path).write_text(html_of(column(*body), title), encoding="utf-8")
