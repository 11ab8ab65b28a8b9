"""The *Calibration* tab: which manoeuvres calibrate a ship's magnetometer (seed 004).

``calibration_tab(scenario)`` returns the tab's layout; its state is the ``cal_`` block of
:class:`app.scenario.Scenario` (plus the uploaded file, which stays in the tab). The numbers come
from :mod:`core.calibration`; :func:`compute` is a pure function of the parameter values and the
uploaded bytes, so tests call it directly.
"""

from __future__ import annotations

import hashlib
import html
from functools import partial

import holoviews as hv
import numpy as np
import pandas as pd
import panel as pn

from core import calibration as cal

from . import offloop
from .maps import refusal
from .scenario import Calibration

hv.extension("bokeh", logo=False)  # as app/views.py: the tab also serves on its own (tests)

#: The parts (app.scenario.PARTS) the tab reads: its own.
READS = ("calibration",)
#: The tab's inputs.
FIELDS = Calibration.names()

_SIM_BE = dict(zip(("cal_be_n", "cal_be_e", "cal_be_d"), cal.SEED004_SIMULATION["be"]))
_T1_BE = dict(zip(("cal_be_n", "cal_be_e", "cal_be_d"), cal.SEED004_TABLE1["be"]))
#: One click loads a case: seed 004's two, and the manoeuvres that make its observability point.
PRESETS = {
    "Seed 004 simulation": dict(_SIM_BE, cal_source="Seed 004 simulation", cal_n_attitudes=12,
                                cal_noise_nt=100.0, cal_angle_noise_deg=0.05, cal_iterations=600,
                                cal_p0_bp_nt=3000.0, cal_seed=4),
    "Seed 004 Table 1": dict(_T1_BE, cal_source="Seed 004 Table 1", cal_noise_nt=100.0 * np.sqrt(3),
                             cal_angle_noise_deg=0.0, cal_iterations=600, cal_p0_bp_nt=3000.0),
    "Four level headings": dict(_SIM_BE, cal_source="Designed manoeuvre", cal_headings="0, 90, 180, 270",
                                cal_roll_deg=0.0, cal_pitch_deg=0.0, cal_n_attitudes=4,
                                cal_noise_nt=100.0, cal_angle_noise_deg=0.05),
    "Headings with roll and pitch": dict(_SIM_BE, cal_source="Designed manoeuvre",
                                         cal_headings="0, 90, 180, 270", cal_roll_deg=10.0,
                                         cal_pitch_deg=5.0, cal_n_attitudes=12, cal_noise_nt=100.0,
                                         cal_angle_noise_deg=0.05),
    "Small P(0): slow filter": dict(_SIM_BE, cal_source="Seed 004 simulation", cal_n_attitudes=12,
                                    cal_noise_nt=100.0, cal_angle_noise_deg=0.05,
                                    cal_iterations=3000, cal_p0_bp_nt=30.0, cal_seed=4),
}

HELP = """
**Ship magnetometer calibration** (seed 004). A magnetometer on a ship reads
B = K·A(ψ, θ, φ)·Be + Bp: the 12 coefficients (K, dimensionless; Bp, nT) are what a calibration
manoeuvre must determine. *Rank* says whether it determines them at all (12 of 12), the *CRLB*
how well (1σ for the reading and angle errors set here, uniform within ± the bounds, σ = bound/√3).
Level headings leave K's third column and Bp confounded (rank 9); a roll or pitch that varies
between attitudes breaks it. The curves are seed 004's Kalman filter (x(0) = 0, P(0) from the
prior σ below, Q = 0) over the readings reused cyclically; dashed lines are the truth (simulated
cases) or the least-squares solution. Upload a CSV with columns B1, B2, B3 (nT), psi, theta, phi
(rad) and set Be for real data.
"""

_K_NAMES = cal.COEFFICIENTS[:9]
_BP_NAMES = cal.COEFFICIENTS[9:]


def parse_headings(text):
    """Headings (deg) from comma- or space-separated text, each within ±360°, returned wrapped
    to (−180°, 180°] (360° is north, as 0°); ValueError saying what is wrong.

    Wrapped, as core's random attitudes are: core takes angles up to 2π rad in magnitude, and
    a heading of ±360° plus the simulated angle error would exceed it ("radians?") although the
    tab accepted it."""
    parts = [p for p in str(text).replace(",", " ").split() if p]
    try:
        vals = [float(p.replace("−", "-")) for p in parts]
    except ValueError:
        raise ValueError(f"Headings must be numbers in degrees separated by commas; got {str(text)[:60]!r}") from None
    if not vals or len(vals) > 72 or not all(np.isfinite(vals)) or max(map(abs, vals)) > 360:
        raise ValueError("Headings must be 1 to 72 numbers in degrees, each within ±360")
    return [180.0 - (180.0 - v) % 360.0 for v in vals]


def compute(values, upload=None):
    """Everything the tab shows, from the cal_ values and the uploaded CSV bytes.

    Returns
    -------
    dict
        ``error`` (str) if the inputs cannot be used; else ``attitudes`` (N, 3) rad, ``be`` (nT),
        ``truth`` (K, Bp) or None, ``obs``, ``crlb`` (12,), ``lsq``, ``kalman``, ``conv`` (iteration),
        ``be_err_kal`` / ``be_err_lsq`` ((N, 3) nT or None), ``be_rms`` (dict), ``note`` (str),
        ``diagnosis`` (:class:`core.calibration.FitDiagnosis`, when N ≥ 4).
    """
    v = values
    be = np.array([v["cal_be_n"], v["cal_be_e"], v["cal_be_d"]], dtype=float)
    sim = cal.SEED004_SIMULATION
    truth = None
    nominal = None  # the attitudes as designed (simulated cases): observability is theirs
    try:
        if not np.linalg.norm(be) > 0:
            raise ValueError("Be must not be zero")
        rng = np.random.default_rng(int(v["cal_seed"]))
        src = v["cal_source"]
        if src in ("Designed manoeuvre", "Seed 004 simulation"):
            truth = (np.array(sim["K"]), np.array(sim["Bp"]))
            n = int(v["cal_n_attitudes"])
            if src == "Designed manoeuvre":
                att = cal.heading_manoeuvre(parse_headings(v["cal_headings"]), roll_deg=v["cal_roll_deg"],
                                            pitch_deg=v["cal_pitch_deg"], n_attitudes=n)
            else:
                att = cal.random_attitudes(n, rng)
            B, rec = cal.simulate_ship_data(*truth, att, be, rng, noise_nt=v["cal_noise_nt"],
                                            angle_noise_deg=v["cal_angle_noise_deg"])
            nominal = att
        elif src == "Seed 004 Table 1":
            B, rec = cal.seed004_table1()
        else:
            if not upload:
                raise ValueError("Upload a CSV file (columns B1, B2, B3 in nT, psi, theta, phi in rad)")
            B, rec = cal.parse_attitude_csv(upload)
        sigma = v["cal_noise_nt"] / np.sqrt(3)
        sig_a = np.deg2rad(v["cal_angle_noise_deg"]) / np.sqrt(3)
        # Rank and CRLB of the manoeuvre as sailed (designed), not of its noisy record: angle
        # errors would make four level headings look barely "rank 12".
        design = rec if nominal is None else nominal
        obs = cal.calibration_observability(design, be)
        out = dict(error=None, attitudes=rec, be=be, truth=truth, obs=obs, note="")
        if rec.shape[0] < 4:
            out.update(crlb=np.full(12, np.inf), lsq=None, kalman=None, conv=None, be_err_kal=None,
                       be_err_lsq=None, be_rms={},
                       note=f"{rec.shape[0]} attitude(s): the 12 coefficients need at least 4.")
            return out
        lsq = cal.lsq_calibrate(B, rec, be)
        K_lin = truth[0] if truth is not None else lsq.K
        crlb = cal.calibration_crlb(design, be, noise_nt=sigma, angle_noise_rad=sig_a, K=K_lin)
        kal = cal.kalman_calibrate(B, rec, be, sigma_nt=sigma, iterations=int(v["cal_iterations"]),
                                   P0=(1.0, 1.0, 1.0, float(v["cal_p0_bp_nt"]) ** 2))
        out.update(crlb=crlb, lsq=lsq, kalman=kal,
                   conv=int(cal.convergence_iteration(kal.coefficients, crlb)),
                   diagnosis=cal.fit_diagnosis(B, rec, be, noise_nt=sigma, angle_noise_rad=sig_a))
        rms = {}
        for key, (K, Bp) in (("kal", (kal.K, kal.Bp)), ("lsq", (lsq.K, lsq.Bp))):
            try:
                est = cal.geomagnetic_solution(B, rec, K, Bp)
            except ValueError:
                out[f"be_err_{key}"] = None
                continue
            out[f"be_err_{key}"] = est - be
            rms[key] = cal.geomagnetic_error(est, be)
        out["be_rms"] = rms
        return out
    except ValueError as exc:
        return dict(error=str(exc))


# --------------------------------------------------------------------------- views
def _fmt(x, unit=""):
    if x is None or not np.isfinite(x):
        return "∞" if x is not None and np.isinf(x) else "—"
    return f"{x:.4g}{unit}".replace("-", "−")


def summary(res):
    """Markdown: rank, unobservable directions, filter and geomagnetic-solution numbers."""
    if res["error"]:
        return ""
    obs = res["obs"]
    lines = [f"**Rank of Γ: {obs.rank} of 12** ({res['attitudes'].shape[0]} attitudes; condition "
             f"number of the column-scaled Γ {_fmt(obs.condition)})."]
    lines += [f"- Unobservable: {html.escape(d, quote=False)}." for d in obs.descriptions]
    if res["note"]:
        lines.append(f"- {html.escape(res['note'], quote=False)}")
    if res["kalman"] is not None:
        lines.append(f"- Kalman filter: within one CRLB σ of its final value after **{res['conv']}** "
                     f"of {res['kalman'].history.shape[-3] - 1} iterations.")
        if res["lsq"].rank < 12:
            lines.append("- Least squares is not unique here (minimum-norm solution shown).")
        if 3 * res["attitudes"].shape[0] == 12:
            lines.append("- 12 readings for 12 unknowns: least squares fits them exactly, so its "
                         "geomagnetic solution has no error to show; the CRLB is the honest measure.")
        # a misfit, an optimistic bound or unbounded coefficients, in words (core's sentences)
        lines += [f"- **{dict(misfit='Misfit', warning='Check', note='Note')[d.level]}:** "
                  f"{html.escape(m, quote=False)}"
                  for d in [res["diagnosis"]] for m in d.messages]
        r = res["be_rms"]
        if r:
            lines.append("- Geomagnetic solution Be = (KA)⁻¹(B − Bp), RMS error per component: "
                         + ", ".join(f"{'Kalman' if k == 'kal' else 'least squares'} "
                                     f"**{e.rms_nt:.1f} nT** (largest {100 * e.max_rel:.2f} % of |Be|)"
                                     for k, e in r.items()) + ".")
    return "\n".join(lines)


def coefficient_table(res):
    """DataFrame: per coefficient its truth (if known), the Kalman and LSQ estimates, the CRLB."""
    if res["error"]:
        return pd.DataFrame()
    rows = []
    truth = None if res["truth"] is None else np.r_[res["truth"][0].ravel(), res["truth"][1]]
    kal = None if res["kalman"] is None else res["kalman"].coefficients[-1]
    lsq = None if res["lsq"] is None else np.r_[res["lsq"].K.ravel(), res["lsq"].Bp]
    for j, (c, u) in enumerate(zip(cal.COEFFICIENTS, cal.COEFFICIENT_UNITS)):
        unit = "" if u == "1" else " nT"
        rows.append({
            "coefficient": c, "unit": "dimensionless" if u == "1" else "nT",
            "observable": bool(res["obs"].observable[j]),
            "truth": _fmt(None if truth is None else truth[j], unit),
            "Kalman": _fmt(None if kal is None else kal[j], unit),
            "least squares": _fmt(None if lsq is None else lsq[j], unit),
            "CRLB σ": _fmt(res["crlb"][j], unit),
            "(Kalman − truth)/σ": _fmt(None if truth is None or kal is None or not np.isfinite(res["crlb"][j])
                                       else (kal[j] - truth[j]) / res["crlb"][j]),
        })
    return pd.DataFrame(rows)


_OPTS = dict(responsive=True, height=320, show_grid=True, tools=["hover"], legend_position="right")


def _empty(xlabel, ylabel, title):
    return hv.Curve([], hv.Dimension("x", label=xlabel), hv.Dimension("y", label=ylabel)).opts(
        title=title, responsive=True, height=320, show_grid=True)


def convergence_plot(res, which):
    """Seed 004's Figs. 1 / 3: estimates vs iteration (``which`` = "K" or "Bp")."""
    names = _K_NAMES if which == "K" else _BP_NAMES
    ylabel = "K entry (dimensionless)" if which == "K" else "Bp (nT)"
    title = f"Kalman filter: {which} vs iteration"
    if res["error"] or res["kalman"] is None:
        return _empty("Iteration n (log scale)", ylabel, title)
    h = res["kalman"].coefficients[1:]  # after each step: n = 1…M on a log axis (x(0) = 0)
    cols = slice(0, 9) if which == "K" else slice(9, 12)
    n = np.arange(1, h.shape[0] + 1)
    kd = hv.Dimension("n", label="Iteration n (log scale)")
    vd = hv.Dimension("value", label=ylabel)
    curves = [hv.Curve((n, h[:, cols][:, j]), kd, vd, label=name) for j, name in enumerate(names)]
    ref = (np.r_[res["truth"][0].ravel(), res["truth"][1]] if res["truth"] is not None
           else np.r_[res["lsq"].K.ravel(), res["lsq"].Bp])[cols]
    lines = [hv.HLine(r).opts(line_dash="dashed", color="grey", line_width=1) for r in ref]
    return hv.Overlay(curves + lines).opts(
        title=title + (" (dashed: truth)" if res["truth"] is not None else " (dashed: least squares)"),
        logx=True, **_OPTS)


#: Most attitudes a plot draws: a real log has tens of thousands, which the browser need not get
#: (every attitude is in the numbers above; the plots show an even selection and say so).
MAX_PLOT_POINTS = 2000


def _shown(n):
    """(indices, title note) of the attitudes 0…n−1 a plot draws: all, or MAX_PLOT_POINTS evenly."""
    if n <= MAX_PLOT_POINTS:
        return np.arange(n), ""
    return (np.unique(np.linspace(0, n - 1, MAX_PLOT_POINTS).round().astype(int)),
            f" ({MAX_PLOT_POINTS:,} of {n:,} attitudes shown)")


def be_error_plot(res):
    """Per attitude, the error of the geomagnetic solution Be = (KA)⁻¹(B − Bp), Kalman K and Bp."""
    title = "Geomagnetic solution error (Kalman K, Bp)"
    ylabel = "Be error (nT)"
    if res["error"] or res.get("be_err_kal") is None:
        return _empty("Attitude n", ylabel, title)
    idx, shown = _shown(res["be_err_kal"].shape[0])
    e = res["be_err_kal"][idx]
    title += shown
    kd = hv.Dimension("attitude", label="Attitude n")
    vd = hv.Dimension("error", label=ylabel)
    n = idx + 1
    layers = []
    for i, lab in enumerate(("north", "east", "down")):
        layers += [hv.Curve((n, e[:, i]), kd, vd, label=lab),
                   hv.Scatter((n, e[:, i]), kd, vd, label=lab).opts(size=6)]
    return hv.Overlay(layers).opts(title=title, **_OPTS)


def manoeuvre_plot(res):
    """The attitudes: roll against heading, coloured by pitch (degrees)."""
    title = "Manoeuvre: attitudes"
    if res["error"]:
        return _empty("Heading ψ (°)", "Roll θ (°)", title)
    idx, shown = _shown(res["attitudes"].shape[0])
    title += shown
    a = np.rad2deg(res["attitudes"][idx])
    df = pd.DataFrame({"heading": np.mod(a[:, 0], 360), "roll": a[:, 1], "pitch": a[:, 2],
                       "n": idx + 1})
    return hv.Scatter(df, hv.Dimension("heading", label="Heading ψ (°)"),
                      [hv.Dimension("roll", label="Roll θ (°)"), hv.Dimension("pitch", label="Pitch φ (°)"),
                       hv.Dimension("n", label="Attitude n")]).opts(
        color="pitch", cmap="coolwarm", colorbar=True, size=9, title=title, responsive=True,
        height=320, show_grid=True, tools=["hover"], xlim=(-10, 370),
        clabel="Pitch φ (°)")


def _error_html(res):
    if not res["error"]:
        return ""
    return (f'<div class="alert alert-danger" role="alert" style="color:#842029;background:#f8d7da;'
            f'border-radius:6px;padding:10px 14px">{html.escape(res["error"])}</div>')


def _load(scenario, name):
    """A preset's values in one go: widgets, table and plots reach the browser together."""
    with pn.io.hold():
        scenario.update(PRESETS[name])


def views(values, upload=None):
    """Everything the tab draws for the cal_ ``values`` and the ``upload``ed bytes: dict of the
    error HTML, the summary markdown, the coefficient table and the four plots (built on a
    worker thread, :mod:`app.offloop`; drawn on the event loop)."""
    res = compute(values, upload)
    return dict(error=_error_html(res), summary=summary(res), table=coefficient_table(res),
                K=convergence_plot(res, "K"), Bp=convergence_plot(res, "Bp"),
                be=be_error_plot(res), manoeuvre=manoeuvre_plot(res))


def calibration_tab(scenario):
    """The tab's layout for one session's ``scenario`` (its ``cal_`` parameters). A change of
    the inputs or an upload computes off the event loop (:class:`app.offloop.Task`, ~3 s for a
    50,000-reading log), a spinner over the results and plots meanwhile."""
    upload = pn.widgets.FileInput(accept=".csv", css_classes=["w-cal-upload"])

    def uploaded(event):
        if event.new:
            scenario.calibration.cal_source = "Uploaded CSV"

    upload.param.watch(uploaded, "value")
    error = pn.pane.HTML("", sizing_mode="stretch_width", css_classes=["w-cal-error"])
    text = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["w-cal-summary"])
    table = pn.pane.DataFrame(pd.DataFrame(), index=False, sizing_mode="stretch_width",
                              css_classes=["w-cal-table"])
    k_plot, bp_plot, be_plot, att_plot = (pn.pane.HoloViews(None, sizing_mode="stretch_width")
                                          for _ in range(4))
    results = pn.Column(refusal(scenario, FIELDS, "w-message-cal"), error, text, table, sizing_mode="stretch_width")
    plots = pn.Column(pn.Row(k_plot, bp_plot, sizing_mode="stretch_width"),
                      pn.Row(be_plot, att_plot, sizing_mode="stretch_width"),
                      sizing_mode="stretch_width")
    task = offloop.Task("calibration", busy=[results, plots])

    def show(shown):
        error.object, text.object, table.object = shown["error"], shown["summary"], shown["table"]
        k_plot.object, bp_plot.object = shown["K"], shown["Bp"]
        be_plot.object, att_plot.object = shown["be"], shown["manoeuvre"]

    def failed(exc):  # compute says what is wrong with the inputs; anything else is said here
        error.object = _error_html(dict(error=f"Not computed: {type(exc).__name__}: {exc}"))

    def start(*_):
        with task.lock:  # the values as they are when this decides (two watchers may race)
            values = scenario.values(READS)
            data = upload.value
            key = (tuple(sorted(values.items())), hashlib.sha1(data).hexdigest() if data else None)
            task.start(key, partial(views, values, data), show, failed)

    scenario.watch(start, READS)
    upload.param.watch(start, "value")
    start()
    presets = pn.FlexBox(*[
        pn.widgets.Button(name=name, button_type="primary", button_style="outline",
                          css_classes=[f"w-cal-preset-{i}"],
                          on_click=lambda e, n=name: _load(scenario, n))
        for i, name in enumerate(PRESETS)], sizing_mode="stretch_width")
    number = {"type": pn.widgets.FloatInput, "sizing_mode": "stretch_width"}
    widgets = {f: dict(number, css_classes=[f"w-{f}"]) for f in FIELDS}
    widgets.update(cal_source={"type": pn.widgets.Select, "css_classes": ["w-cal_source"]},
                   cal_headings={"type": pn.widgets.TextInput, "css_classes": ["w-cal_headings"]},
                   cal_n_attitudes={"type": pn.widgets.IntInput, "css_classes": ["w-cal_n_attitudes"]},
                   cal_iterations={"type": pn.widgets.IntInput, "css_classes": ["w-cal_iterations"]},
                   cal_seed={"type": pn.widgets.IntInput, "css_classes": ["w-cal_seed"]})
    controls = pn.Column(
        pn.Param(scenario.calibration, parameters=list(FIELDS), widgets=widgets, show_name=False,
                 sizing_mode="stretch_width"),
        pn.pane.Markdown(f"**Upload a CSV** (B1, B2, B3 in nT; psi, theta, phi in rad; at most "
                         f"{cal.MAX_CSV_ROWS:,} rows and {cal.MAX_CSV_BYTES // 2 ** 20} MiB)"), upload,
        width=320)
    return pn.Column(
        pn.pane.Markdown(HELP, sizing_mode="stretch_width"),
        pn.pane.Markdown("**Seed 004's cases and instructive manoeuvres** (one click loads one)"), presets,
        pn.Row(controls, results, sizing_mode="stretch_width"),
        plots, sizing_mode="stretch_width")
