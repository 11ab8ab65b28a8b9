"""The *Calibration* tab: which manoeuvres calibrate a ship's magnetometer (seed 004).

``calibration_tab(scenario)`` returns the tab's layout; its state is the ``cal_`` block of
:class:`app.state.scenario.Scenario` (plus the uploaded file, which stays in the tab). The numbers come
from :mod:`core.calibration`; :func:`compute` is a pure function of the parameter values and the
uploaded bytes, so tests call it directly.
"""

from __future__ import annotations

import hashlib
import html
from functools import partial

import numpy as np
import pandas as pd
import panel as pn
import param

from core import calibration as cal

from app.kit import offloop
from app.kit.alerts import refusal
from app.kit.number_box import number_box
from app.kit.tab import Tab
from app.state.part import declared
from app.state.presets import presets
from app.state.scenario import Calibration
from .plots import Figures, plot_data
from .sources import readings

#: The parts (app.state.scenario.PARTS) the tab reads: its own.
READS = ("calibration",)
#: The tab's inputs.
FIELDS = Calibration.names()

#: The geomagnetic field's inputs (north, east, down), as declared (``vector="Be"``).
BE = tuple(n for n in FIELDS if declared(Calibration.param[n]).get("vector") == "Be")
#: One click loads a case: seed 004's two, and the manoeuvres that make its observability point
#: (seed 004's eq. (2) convention): the scenario files of app/state/presets/calibration/.
PRESETS = presets("calibration")


def applies(name, source):
    """Whether the input of ``name`` (one of FIELDS) applies to the data source ``source``, as
    declared (``sources``: the design's shape to a designed manoeuvre; the number of attitudes
    and the seed of the simulated errors to the simulated sources; the noise, Be, convention and
    filter settings, declaring none, to every source)."""
    return source in declared(Calibration.param[name]).get("sources", (source,))

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


def compute(values, upload=None):
    """Everything the tab shows, from the cal_ values and the uploaded CSV bytes.

    Returns
    -------
    dict
        ``error`` (str) if the inputs cannot be used; else ``attitudes`` (N, 3) rad, ``be`` (nT),
        ``convention``, ``truth`` (K, Bp) or None, ``obs``, ``crlb`` (12,), ``lsq``, ``kalman``,
        ``conv`` (iteration), ``be_err_kal`` / ``be_err_lsq`` ((N, 3) nT or None), ``be_rms``
        (dict), ``note`` (str), ``diagnosis`` (:class:`core.calibration.FitDiagnosis`, when
        N ≥ 4) and ``from_residuals`` (None, or when the residual says the stated noise is off
        by more than chance: ``sigma_nt``, the reading σ the residuals give, ``bound_nt`` its
        ± bound (the input's unit) and ``crlb`` (12,) for it); ``printed``: seed 004's own solution
        of its Table 1 (``K``, ``Bp``, ``be_rms_nt``, ``be_max_rel``; ``be_rms["printed"]``) or None.
    """
    v = values
    be = np.array([v[n] for n in BE], dtype=float)
    conv = v.get("cal_convention", "seed004")
    src = v["cal_source"]
    try:
        if not np.linalg.norm(be) > 0:
            raise ValueError("Be must not be zero")
        B, rec, truth, nominal = readings(v, be, conv, upload)
        sigma = v["cal_noise_nt"] / np.sqrt(3)
        sig_a = np.deg2rad(v["cal_angle_noise_deg"]) / np.sqrt(3)
        # Rank and CRLB of the manoeuvre as sailed (designed), not of its noisy record: angle
        # errors would make four level headings look barely "rank 12".
        design = rec if nominal is None else nominal
        obs = cal.calibration_observability(design, be, convention=conv)
        t1 = cal.SEED004_TABLE1  # seed 004's own solution of its Table 1, beside the tab's
        printed = (dict(K=np.array(t1["paper_K"]), Bp=np.array(t1["paper_Bp"]), be_rms_nt=t1["paper_be_rms_nt"],
                        be_max_rel=t1["paper_be_max_rel"]) if src == "Seed 004 Table 1" else None)
        out = dict(error=None, attitudes=rec, be=be, convention=conv, truth=truth, obs=obs, note="",
                   from_residuals=None, printed=printed)
        if rec.shape[0] < 4:
            out.update(crlb=np.full(12, np.inf), lsq=None, kalman=None, conv=None, be_err_kal=None,
                       be_err_lsq=None, be_rms={},
                       note=f"{rec.shape[0]} attitude(s): the 12 coefficients need at least 4.")
            return out
        lsq = cal.lsq_calibrate(B, rec, be, convention=conv)
        K_lin = truth[0] if truth is not None else lsq.K
        crlb = cal.calibration_crlb(design, be, noise_nt=sigma, angle_noise_rad=sig_a, K=K_lin,
                                    convention=conv)
        kal = cal.kalman_calibrate(B, rec, be, sigma_nt=sigma, iterations=int(v["cal_iterations"]),
                                   P0=(1.0, 1.0, 1.0, float(v["cal_p0_bp_nt"]) ** 2), convention=conv)
        diag = cal.fit_diagnosis(B, rec, be, noise_nt=sigma, angle_noise_rad=sig_a, convention=conv)
        out.update(crlb=crlb, lsq=lsq, kalman=kal,
                   conv=int(cal.convergence_iteration(kal.coefficients, crlb)), diagnosis=diag,
                   from_residuals=_from_residuals(diag, design, be, sig_a, K_lin, conv))
        rms = {}
        solutions = [("kal", (kal.K, kal.Bp)), ("lsq", (lsq.K, lsq.Bp))]
        if printed is not None:  # seed 004's K and Bp on the same readings, in this convention
            solutions.append(("printed", (printed["K"], printed["Bp"])))
        for key, (K, Bp) in solutions:
            try:
                est = cal.geomagnetic_solution(B, rec, K, Bp, convention=conv)
            except ValueError:
                out[f"be_err_{key}"] = None
                continue
            out[f"be_err_{key}"] = est - be
            rms[key] = cal.geomagnetic_error(est, be)
        out["be_rms"] = rms
        return out
    except ValueError as exc:
        return dict(error=str(exc))


def _from_residuals(diag, design, be, sig_a, K, conv):
    """The reading σ the residuals give (:attr:`core.calibration.FitDiagnosis.reading_sigma_hat_nt`),
    its ± bound (the input's unit) and the CRLB for it, when the stated noise is off by more than
    chance and the model fits (:attr:`~core.calibration.FitDiagnosis.noise_misstated`); else None."""
    if not diag.noise_misstated:
        return None
    s = diag.reading_sigma_hat_nt
    return dict(sigma_nt=s, bound_nt=s * np.sqrt(3),
                crlb=cal.calibration_crlb(design, be, noise_nt=s, angle_noise_rad=sig_a, K=K,
                                          convention=conv))


# --------------------------------------------------------------------------- views
def _fmt(x, unit=""):
    """A number as shown: 4 significant digits (no float noise such as 173.20508075688772)."""
    if x is None or not np.isfinite(x):
        return "∞" if x is not None and np.isinf(x) else "—"
    return f"{x:.4g}{unit}".replace("-", "−")


def _names(names):
    names = list(names)
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def unidentifiable(res):
    """Names of the coefficients the manoeuvre (as designed) does not determine: CRLB ∞."""
    return tuple(c for c, ok in zip(cal.COEFFICIENTS, res["obs"].observable) if not ok)


#: fit_diagnosis's sentence on unbounded coefficients (its rank is the record's): the tab says it
#: for the manoeuvre as designed instead, once (a record's angle errors can hide a rank of 9).
_UNBOUNDED_WORDS = "are unbounded (CRLB ∞)"


def summary(res):
    """Markdown: rank, unobservable directions, filter and geomagnetic-solution numbers."""
    if res["error"]:
        return ""
    obs = res["obs"]
    lost = unidentifiable(res)
    lines = [f"**Rank of Γ: {obs.rank} of 12** ({res['attitudes'].shape[0]} attitudes; condition "
             f"number of the column-scaled Γ {_fmt(obs.condition)})."]
    lines += [f"- Unobservable: {html.escape(d, quote=False)}." for d in obs.descriptions]
    if lost:
        lines.append(
            f"- **Not identifiable: {_names(lost)}** ({len(lost)} of the 12 coefficients, CRLB ∞). "
            "This manoeuvre cannot determine them: their estimates in the table are arbitrary, one "
            "of infinitely many that fit the readings equally well, however small the residual or "
            "the geomagnetic-solution error below. Add roll or pitch that varies between attitudes.")
    if res["note"]:
        lines.append(f"- {html.escape(res['note'], quote=False)}")
    if res["kalman"] is not None:
        iters = res["kalman"].history.shape[-3] - 1
        if lost:  # no bound, so no "within one CRLB σ" for the filter as a whole
            lines.append(f"- Kalman filter ({iters} iterations): no convergence to report, as the "
                         "coefficients that are not identifiable have no bound; their values follow "
                         "the prior P(0), not the data.")
        else:
            lines.append(f"- Kalman filter: within one CRLB σ of its final value after **{res['conv']}** "
                         f"of {iters} iterations.")
        if res["lsq"].rank < 12:
            lines.append("- Least squares is not unique here (minimum-norm solution shown).")
        d = res["diagnosis"]
        if 3 * res["attitudes"].shape[0] == 12 and d.dof > 0 and not lost:  # (else core says it)
            lines.append("- 12 readings for 12 unknowns: least squares fits them exactly, so its "
                         "geomagnetic solution has no error to show; the CRLB is the honest measure.")
        # a misfit, an optimistic bound or unbounded coefficients, in words (core's sentences).
        # Core judges the attitudes as recorded: with a rank-deficient design its words on the
        # unbounded coefficients, or on a record that angle errors made exactly determined, are
        # replaced by the design's, above.
        lines += [f"- **{dict(misfit='Misfit', warning='Check', note='Note')[d.level]}:** "
                  f"{html.escape(m, quote=False)}"
                  for m in d.messages if not (lost and (_UNBOUNDED_WORDS in m or d.dof == 0))]
        fr = res["from_residuals"]
        if fr is not None:
            lines.append(f"- With σ from the residuals ({_fmt(fr['sigma_nt'], ' nT')}, a reading error "
                         f"bound of ± {_fmt(fr['bound_nt'], ' nT')}) the CRLB is the column "
                         "*CRLB σ from residuals*; the button below sets that noise.")
        r = res["be_rms"]
        if r:
            names = {"kal": "Kalman", "lsq": "least squares", "printed": "seed 004's printed K and Bp"}
            said = ", ".join(f"{names[k]} **{e.rms_nt:.1f} nT** (largest {100 * e.max_rel:.2f} % of |Be|)"
                             for k, e in r.items())
            if res.get("printed") is not None:  # seed 004's own figures for its Table 1
                said += (f" (seed 004 prints {res['printed']['be_rms_nt']:g} nT and {100 * res['printed']['be_max_rel']:.1f} %, "
                         "from a geomagnetic filter of its own)")
            if lost:
                lines.append(f"- Geomagnetic solution Be = (KA)⁻¹(B − Bp) on these attitudes, RMS "
                             f"error per component: {said}. Not a check of K and Bp: the "
                             "unidentifiable combinations leave these attitudes' readings "
                             "unchanged, so any of them gives this Be here, and at another roll or "
                             "pitch the error has no bound.")
            else:
                lines.append(f"- Geomagnetic solution Be = (KA)⁻¹(B − Bp), RMS error per component: "
                             f"{said}.")
    return "\n".join(lines)


def coefficient_table(res):
    """DataFrame: per coefficient its truth (if known), the Kalman and LSQ estimates, seed 004's
    printed solution (its Table 1), the CRLB (and the CRLB for σ from the residuals when that
    differs from the stated σ). Without a truth (Table 1, an upload) no truth columns: they were
    "—" throughout, and cut the table off at 1280 px."""
    if res["error"]:
        return pd.DataFrame()
    rows = []
    truth = None if res["truth"] is None else np.r_[res["truth"][0].ravel(), res["truth"][1]]
    kal = None if res["kalman"] is None else res["kalman"].coefficients[-1]
    lsq = None if res["lsq"] is None else np.r_[res["lsq"].K.ravel(), res["lsq"].Bp]
    fr = res.get("from_residuals")
    printed = res.get("printed")
    printed = None if printed is None else np.r_[printed["K"].ravel(), printed["Bp"]]
    for j, (c, u) in enumerate(zip(cal.COEFFICIENTS, cal.COEFFICIENT_UNITS)):
        unit = "" if u == "1" else " nT"
        ok = bool(res["obs"].observable[j])

        def est(x):  # an estimate the manoeuvre does not determine is one of infinitely many
            return _fmt(x, unit) + ("" if ok or x is None else " (arbitrary)")

        row = {
            "coefficient": c, "unit": "dimensionless" if u == "1" else "nT",
            "observable": "yes" if ok else "no: not identifiable",
        }
        row.update({} if truth is None else {"truth": _fmt(truth[j], unit)})
        row.update({"Kalman": est(None if kal is None else kal[j]), "least squares": est(None if lsq is None else lsq[j])})
        row.update({} if printed is None else {"seed 004 (printed)": _fmt(printed[j], unit)})
        row["CRLB σ"] = _fmt(res["crlb"][j], unit)
        if fr is not None:
            row["CRLB σ from residuals"] = _fmt(fr["crlb"][j], unit)
        if truth is not None:
            row["(Kalman − truth)/σ"] = _fmt(None if kal is None or not np.isfinite(res["crlb"][j])
                                             else (kal[j] - truth[j]) / res["crlb"][j])
        rows.append(row)
    return pd.DataFrame(rows)


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
    error HTML, the summary markdown, the coefficient table, the four plots' data
    (:func:`app.tabs.calibration.plots.plot_data`) and the fixes offered (made on a worker thread,
    :mod:`app.kit.offloop`; shown on the event loop)."""
    res = compute(values, upload)
    return dict(error=_error_html(res), summary=summary(res), table=coefficient_table(res),
                plots=plot_data(res), fixes=fixes(res))


def fixes(res):
    """What the diagnosis offers to set, as Scenario values: ``noise`` (the ± bound from the
    residuals' σ), ``convention`` (the one that fits) and ``be`` (Be with a slip undone); each
    None when not offered."""
    if res["error"] or res.get("diagnosis") is None:
        return dict(noise=None, convention=None, be=None)
    d, fr = res["diagnosis"], res["from_residuals"]
    return dict(noise=None if fr is None else {"cal_noise_nt": float(fr["bound_nt"])},
                convention=None if d.suggested_convention is None
                else {"cal_convention": d.suggested_convention},
                be=None if d.suggested_be is None
                else dict(zip(BE, d.suggested_be)))


def _fix_label(kind, values):
    if kind == "noise":
        return f"Use σ from the residuals (reading error ± {_fmt(values['cal_noise_nt'], ' nT')})"
    if kind == "convention":
        return f"Use the '{values['cal_convention']}' attitude convention"
    return "Use Be = [" + ", ".join(_fmt(values[k]) for k in BE) + "] nT"


#: Bytes per piece of an upload. Bokeh's websocket takes messages of at most 20 MB: a 26 MB CSV
#: sent whole (Panel's FileInput) closed the session without a word. Sent in pieces (Panel's
#: FileDropper), any file up to core's :data:`core.calibration.MAX_CSV_BYTES` arrives.
UPLOAD_CHUNK_BYTES = 4_000_000


def upload_widget():
    """The CSV upload: Panel's FileDropper, sending the file in pieces of
    :data:`UPLOAD_CHUNK_BYTES`, refusing in the browser, before anything is sent and with a
    message there, a file larger than core accepts (FilePond's sizes are in units of 1000)."""
    return pn.widgets.FileDropper(multiple=False, chunk_size=UPLOAD_CHUNK_BYTES,
                                  max_file_size=f"{cal.MAX_CSV_BYTES // 1000}KB", layout="compact",
                                  css_classes=["w-cal-upload"], sizing_mode="stretch_width")


def uploaded_bytes(upload):
    """The bytes of the file uploaded last (None if none): Panel decodes a text/* file to str.
    FileDropper's ``value`` keeps every file sent under another name unless the browser deletes
    it: the tab took the first, and a second log sent without that delete was ignored (its key
    was the first's: nothing computed). The newest name is the dict's last."""
    files = upload.value or {}
    if not files:
        return None
    data = next(reversed(files.values()))
    return data.encode("utf-8") if isinstance(data, str) else bytes(data)


def calibration_parts(scenario):
    """The tab's (inputs, results) for one session's ``scenario`` (its ``cal_`` parameters). A change of
    the inputs or an upload computes off the event loop (:class:`app.kit.offloop.Task`, ~1 s for a
    50,000-reading log), a spinner over the results and plots meanwhile."""
    upload = upload_widget()

    def uploaded(event):
        if event.new:
            scenario.calibration.cal_source = "Uploaded CSV"

    upload.param.watch(uploaded, "value")
    error = pn.pane.HTML("", sizing_mode="stretch_width", css_classes=["w-cal-error"])
    text = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["w-cal-summary"])
    # What the diagnosis offers to set (fixes()): one button each, shown when offered.
    LABEL = "label" if "label" in pn.widgets.Button.param else "name"
    offered = {}
    buttons = {kind: pn.widgets.Button(name="", button_type="warning", button_style="outline",
                                       visible=False, css_classes=[f"w-cal-fix-{kind}"])
               for kind in ("noise", "convention", "be")}
    for kind, button in buttons.items():
        button.on_click(lambda e, k=kind: offered.get(k) and _set(scenario, offered[k]))
    table = pn.pane.DataFrame(pd.DataFrame(), index=False, sizing_mode="stretch_width",
                              css_classes=["w-cal-table"])
    figures = Figures()  # built once; a result only replaces their data (app.tabs.calibration.plots)
    k_plot, bp_plot, be_plot, att_plot = (pn.pane.Bokeh(figures.figures[k], sizing_mode="stretch_width")
                                          for k in ("K", "Bp", "be", "manoeuvre"))
    results = pn.Column(error, text,
                        pn.FlexBox(*buttons.values(), sizing_mode="stretch_width"), table,
                        sizing_mode="stretch_width")
    plots = pn.Column(pn.Row(k_plot, bp_plot, sizing_mode="stretch_width"),
                      pn.Row(be_plot, att_plot, sizing_mode="stretch_width"),
                      sizing_mode="stretch_width")
    task = offloop.Task("calibration", busy=[results, plots])

    def show(shown):
        error.object, text.object, table.object = shown["error"], shown["summary"], shown["table"]
        figures.show(shown["plots"])
        offered.clear()
        offered.update(shown["fixes"])
        for kind, button in buttons.items():
            values = offered[kind]
            # its text: ``label`` from Panel 1.9; before it ``name``, constant after creation
            with param.edit_constant(button):
                button.param.update(**{LABEL: _fix_label(kind, values) if values else ""},
                                    visible=bool(values))

    def failed(exc):  # compute says what is wrong with the inputs; anything else is said here
        error.object = _error_html(dict(error=f"Not computed: {type(exc).__name__}: {exc}"))

    def start(*_):
        with task.lock:  # the values as they are when this decides (two watchers may race)
            values = scenario.values(READS)
            data = uploaded_bytes(upload)
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
    # a refused input is said above the inputs, where the user types (they sit in the sidebar)
    controls = pn.Column(
        refusal(scenario, FIELDS, "w-message-cal"),
        *[_input(scenario, f) for f in FIELDS],
        pn.pane.Markdown(f"**Upload a CSV** (B1, B2, B3 in nT; psi, theta, phi in rad; at most "
                         f"{cal.MAX_CSV_ROWS:,} rows and {cal.MAX_CSV_BYTES / 1e6:.1f} MB: a larger "
                         "file is refused here, before it is sent)"), upload,
        sizing_mode="stretch_width", css_classes=["w-cal-inputs"])
    main = pn.Column(
        pn.pane.Markdown(HELP, sizing_mode="stretch_width"),
        pn.pane.Markdown("**Seed 004's cases and instructive manoeuvres** (one click loads one)"), presets,
        results, plots, sizing_mode="stretch_width")
    return controls, main


def calibration_tab(scenario):
    """The tab as one layout: its inputs beside its results (the page puts the inputs in its
    sidebar instead: :func:`calibration_parts`)."""
    controls, main = calibration_parts(scenario)
    return pn.Row(pn.Column(controls, width=320), main, sizing_mode="stretch_width")


#: Decimals shown in the tab's number boxes (app.kit.number_box): up to 4, so that a value such as the
#: Table 1 preset's 100·√3 shows as 173.2051, not 173.20508075688772 (the value keeps every digit).
NUMBER_DECIMALS = 4


def _input(scenario, name):
    """The widget of parameter ``name`` (from the parameter), shown only while it applies to the
    chosen data source (:func:`applies`)."""
    p = scenario.ref(name)
    visible = pn.bind(lambda source: applies(name, source), scenario.ref("cal_source"))
    opts = dict(css_classes=[f"w-{name}"], sizing_mode="stretch_width", visible=visible)
    if isinstance(p, param.Selector):
        return pn.widgets.Select.from_param(p, **opts)
    if isinstance(p, param.String):
        return pn.widgets.TextInput.from_param(p, **opts)
    # a box that says why it refuses (Bokeh's spinners dropped -3, 500 or abc in the browser)
    return number_box(scenario.calibration, name, decimals=NUMBER_DECIMALS, **opts)


def _set(scenario, values):
    """Set what a diagnosis button offers, in one update (as a preset)."""
    with pn.io.hold():
        scenario.update(values)


#: The Calibration tab, as the page mounts it (app.kit.tab): its inputs in the sidebar.
TAB = Tab("calibration", "Calibration", reads=tuple(FIELDS), sidebar=True,
          view=lambda m: calibration_parts(m.scenario))
