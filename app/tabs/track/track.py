"""The Track tab: a straight track over the current stations, its PCRLB, and real trackers on it.

``track_tab(scenario)`` returns the tab's layout, a pure function of the shared
:class:`app.state.scenario.Scenario`: its ``track_*`` parameters (start, heading, speed, duration,
sensor axes, process noise, tracker, runs) and, from the rest of the scenario, the design tab's
``stations``, the target depth ``z``, ``T`` and the sensor kind (``sensor``): electric, the
moments ``Ph``/``Pv``, ``noise``, ``sigma`` and the sea (``sea_model``, ``sea_depth``,
``seabed_sigma``: :func:`sea_of`); magnetic (magnetometer, gradiometer or both), the moment
``mx``/``my``/``mz`` (A·m²) and ``noise_b``/``noise_g`` — the same ``core.Sensor`` the maps use,
through the same EKF, PU-EKF and seed 001's filter bank (for a magnetic kind its hypotheses are
vertical moments of ½, 1 and 2 × |m|: :meth:`core.Sensor.bank_moments`).

It shows

- a plan view: stations, the true track coloured by the PCRLB position σ along it (hover: time,
  position, bound, range; crosses where the linearised bound stops predicting,
  :func:`core.linearisation_breaks`), the estimated tracks of the runs (for the bank: every
  filter of run 1 in grey and the ML-selected track highlighted);
- TRMSE (seed 001 eq. (18)) against the PCRLB over time, log scale;
- a line of numbers (diverged share, the bank's winner, NEES).

Everything is computed by :mod:`core.track` (the same Monte-Carlo code as the command line),
cached per set of inputs, computed off the server's event loop (:mod:`app.kit.offloop`).
"""

from __future__ import annotations

import dataclasses
import math
from functools import partial

import holoviews as hv
import numpy as np
import panel as pn
import param

import core
from core.tracking import montecarlo as core_track

# The maps' lock on numba's parallel kernels (its workqueue layer must not be entered from two
# threads at once): the tab's Monte-Carlo takes it too (app.kit.cache).
from app.kit import offloop, views
from app.kit.alerts import refusal
from app.kit.cache import KERNEL_LOCK, SHARED
from app.kit.inputs import number_input
from app.kit.runaway import RUNAWAY_LIMIT, nearest_range
from app.kit.shown import ALWAYS
from app.kit.tab import Tab
from app.kit.views import Design
from app.state.scenario import SENSORS, Scenario, inputs
from app.state.sensors import BY_KIND
from app.state.snapshot import Snapshot

hv.extension("bokeh", logo=False)

#: The inputs the track's numbers are computed from (their key in the cache): the target's
#: sources and depth (the track sets its own motion), the custom stations (not the paper's h, d
#: and layout), the sea, the sensor, and the tab's own settings. tests/test_tab_keys.py checks
#: them against what :func:`_compute` reads.
READS = (*inputs("target", "medium", "sensor", "track", but=("speed", "heading", "model", "state_set")),
         "stations")
#: Prior σ of the EKF/PU-EKF start for a magnetic target: position and velocity as the electric
#: case's (x, y 20 m, z 0.5 m, v 0.5 m/s); each moment entry this share of |m| (at least 1 A·m²).
MAGNETIC_PRIOR_SHARE = 0.2
#: Most steps of a track the tab computes (the duration's bound over the smallest T).
MAX_STEPS = 2001
#: The plan view's frame side (px; the window is square): fits beside the inputs at 1280 × 800.
PLAN_PX = 440
#: Points per side of the CRLB map beneath the track.
MAP_POINTS = 121

WINNER = "#d62728"
TRUTH = "#000000"


def sea_of(s):
    """The scenario's medium: ``core.Sea(sea_depth, seabed_sigma)`` when ``sea_model`` is
    "layered", else None (the whole space) — the same sea the maps use."""
    if s.sea_model != "layered":
        return None
    return core.Sea(float(s.sea_depth), float(s.seabed_sigma))


def magnetic_options(s):
    """For a magnetic sensor kind: the TrackCase keywords of its ``core.Sensor``, moment and
    prior; {} for the electric kind."""
    kind = SENSORS[s.sensor]
    if kind == "E":
        return {}
    noise = {"B": s.noise_b, "G": s.noise_g, "BG": (s.noise_b, s.noise_g)}[kind]
    moments = (float(s.mx), float(s.my), float(s.mz))
    sm = max(1.0, MAGNETIC_PRIOR_SHARE * float(np.linalg.norm(moments)))
    m = max(1.0, float(np.linalg.norm(moments)))
    baseline = s.baseline if "G" in kind and s.baseline > 0 else None
    return dict(sensor=core.Sensor(kind, noise, baseline=baseline), moments=moments,
                prior_std=(20.0, 20.0, 0.5, 0.5, 0.5, sm, sm, sm),
                bank_strengths=(0.5 * m, m, 2.0 * m))


#: The command line's sea-trial case (``python -m core.track --case seed001-trial``): the
#: *Seed 001 sea trial* preset sets the Track tab's inputs to it, and :func:`case_of` then uses
#: its priors too, so that the page's numbers are the command line's (docs/tracking.md).
TRIAL = core_track.CASES["seed001-trial"]
#: The TrackCase fields that are priors rather than inputs of the page.
_PRIORS = ("prior_std", "bank_depth_std", "bank_pv_std")


def tracker_of(s):
    """(the tracker the tab runs, why it is not the one chosen or ''): every tracker runs on
    every sensor kind, so the one chosen."""
    return s.track_filter, ""


def case_of(s):
    """The :class:`core.track.TrackCase` of a scenario's values (the command line's
    ``seed001-trial`` case, priors included, when the inputs are that case's)."""
    steps = int(round(s.track_duration / s.T)) + 1
    if steps > MAX_STEPS:
        raise ValueError(f"the track has {steps} steps (duration / T + 1); at most {MAX_STEPS}: "
                         "shorten it or lengthen T")
    magnetic = magnetic_options(s)
    sea = None if magnetic else sea_of(s)  # a static magnetic field does not see the sea
    case = core_track.TrackCase(
        name="track tab", stations=tuple(map(tuple, s.stations)), axes=int(s.track_axes),
        start=(float(s.track_x0), float(s.track_y0), float(s.z)),
        heading=math.radians(s.track_heading), speed=float(s.track_speed), steps=max(steps, 2),
        T=float(s.T), Ph=float(s.Ph), Pv=float(s.Pv), noise=float(s.noise), sigma=float(s.sigma),
        sea_depth=None if sea is None else sea.depth,
        seabed_sigma=None if sea is None else sea.seabed_sigma,
        sigma_a=float(s.track_sigma_a), alpha=float(s.track_alpha), bank_depth=float(s.z),
        bank_pv_std=max(30.0, 2.0 * abs(float(s.Pv))), **magnetic,
    )
    as_trial = dataclasses.replace(case, name=TRIAL.name, **{f: getattr(TRIAL, f) for f in _PRIORS})
    if as_trial == TRIAL:
        return dataclasses.replace(as_trial, name="track tab: seed001-trial")
    return case


def _compute(snapshot: Snapshot):
    """The tab's numbers for a snapshot of :data:`READS` (in the one cache, app.kit.cache.SHARED)."""
    s = snapshot.scenario()
    case = case_of(s)
    with KERNEL_LOCK:
        res = core_track.monte_carlo(case, filter=tracker_of(s)[0], runs=int(s.track_runs), seed=0,
                                     workers=1, keep_tracks=int(s.track_runs))
    truth = case.nominal_track()
    stations = np.asarray(case.stations, float)
    rng = nearest_range(truth[:, :3], stations)
    breaks = core.linearisation_breaks(res.pcrlb_m, rng, limit=RUNAWAY_LIMIT)
    window = view_window(truth)
    plane = core.Plane("xy", window[0], window[1], float(s.z), MAP_POINTS)
    medium = dict(moments=case.moments if case.sensor is not None else (case.Ph, case.Pv),
                  sensor=case.sensors().sensor)  # the case's one measurement (sea_of(s) electric)
    with KERNEL_LOCK:  # the snapshot bound beneath the track: N instants at the track's velocity
        errors = core.crlb_maps(plane, stations, velocity=tuple(truth[0, 3:5]), T=case.T,
                                steps=int(s.steps), **medium)
    return dict(case=case, res=res, truth=truth, range_m=rng, breaks=breaks, stations=stations,
                map=Design(plane=plane, stations=stations, errors=errors), window=window,
                tracker_note=tracker_of(s)[1])


def view_window(truth):
    """((x min, x max), (y min, y max)) of the plan view (m): the track with a margin, square."""
    span = np.ptp(truth[:, :2], axis=0).max() + 60.0
    c = truth[:, :2].mean(axis=0)
    return tuple((float(m - span / 2), float(m + span / 2)) for m in c)


def compute(scenario: Scenario):
    """The tab's numbers for a scenario (cached): dict with the case, the
    :class:`core.track.MonteCarloResult`, the true track, range to the nearest station (m) and
    the linearisation flag at every step."""
    return SHARED.get(Snapshot.of(scenario, READS), _compute)


def plan_view(out):
    """Plan view (x–y, m): stations, the true track coloured by the PCRLB, estimates."""
    res, truth, breaks = out["res"], out["truth"], out["breaks"]
    t = res.time_s
    bound = np.where(np.isfinite(res.pcrlb_m), res.pcrlb_m, np.nan)
    x, y = hv.Dimension("x", unit="m"), hv.Dimension("y", unit="m")
    pts = hv.Points(
        {"x": truth[:, 0], "y": truth[:, 1], "time": t, "pcrlb": bound, "range": out["range_m"],
         "trusted": np.where(breaks, f"no: bound > {RUNAWAY_LIMIT:g} × range", "yes")},
        kdims=[x, y],
        vdims=[hv.Dimension("pcrlb", label="PCRLB σ", unit="m"), hv.Dimension("time", unit="s"),
               hv.Dimension("range", label="range to nearest station", unit="m"),
               hv.Dimension("trusted", label="bound predicts errors")],
        label="true track (colour: PCRLB)",
    ).opts(color="pcrlb", cmap="viridis", logz=True, colorbar=True, size=5, tools=["hover"],
           clabel="PCRLB position σ (m), log scale")  # ticks in metres (they were log10 m under "(m)")
    layers = [map_layer(out["map"]), hv.Path([truth[:, :2]], kdims=[x, y]).opts(color=TRUTH, line_width=1)]
    est = res.tracks["estimate"]
    if res.summary["filter"] == "bank":
        for track in res.tracks["x_all"][0]:
            layers.append(hv.Path([track[:, :2]], kdims=[x, y], label="bank filters, run 1").opts(
                color="#aaaaaa", line_width=1, alpha=0.6, show_legend=True))
        layers.append(hv.Path([est[0, :, :2]], kdims=[x, y], label="ML selection, run 1").opts(
            color=WINNER, line_width=3, show_legend=True))
        others = est[1:]
    else:
        others = est
    if len(others):
        layers.append(hv.Path([e[:, :2] for e in others], kdims=[x, y],
                              label="estimates, other runs").opts(color="#1f77b4", line_width=1, alpha=0.7,
                                                                  show_legend=True))
    layers.append(pts)
    if breaks.any():
        layers.append(hv.Points((truth[breaks, 0], truth[breaks, 1]), kdims=[x, y],
                                label="linearised bound not predictive").opts(
            marker="x", color="#7f7f7f", size=9))
    layers.append(hv.Points((out["stations"][:, 0], out["stations"][:, 1]), kdims=[x, y],
                            label="stations").opts(marker="triangle", color="black", size=12))
    (x0, x1), (y0, y1) = out["window"]
    return hv.Overlay(layers).opts(
        title="Track, PCRLB and estimates over the snapshot CRLB map",  # fits at 1280 px (was cut)
        # the legend under the frame: inside it covered the estimates (issue 25); beside it, it
        # squeezed the frame to ~120 px at 1280 × 800
        # to scale (views.to_scale): equal px per metre in x and y, a fixed frame
        xlim=(x0, x1), ylim=(y0, y1), legend_position="bottom", legend_cols=3,
        **views.to_scale((x0, x1), (y0, y1), PLAN_PX))


def map_layer(d):
    """The snapshot CRLB map beneath the track (grey, darker = smaller bound; hover: log10 m),
    dotted white where it exceeds RUNAWAY_LIMIT × the range, as on the Maps and Layout design tabs."""
    err = np.where(np.isfinite(d.errors.position), d.errors.position, np.nan)
    with np.errstate(divide="ignore"):
        log_err = np.log10(err)
    vdim = hv.Dimension("log10_crlb", label="snapshot CRLB 3-D position σ, log10", unit="log10 m")
    img = views.map_image(log_err, d.plane, vdim).opts(
        cmap="Greys", alpha=0.5, colorbar=False, tools=["hover"], clipping_colors={"NaN": "white"})
    return img * views.runaway_layer(d)


def error_view(out):
    """TRMSE and PCRLB (m, log scale) against time (s)."""
    res, breaks = out["res"], out["breaks"]
    t = hv.Dimension("time", unit="s")
    err = hv.Dimension("error", label="position error", unit="m")
    bound = np.where(np.isfinite(res.pcrlb_m), res.pcrlb_m, np.nan)
    trusted = np.where(breaks, np.nan, bound)
    untrusted = np.where(breaks, bound, np.nan)
    n = res.summary["runs"]
    return hv.Overlay([
        hv.Curve((res.time_s, res.trmse_m), t, err, label=f"TRMSE, {n} runs").opts(
            color=WINNER, tools=["hover"]),
        hv.Curve((res.time_s, trusted), t, err, label="PCRLB position σ").opts(
            color="black", line_dash="dashed", tools=["hover"]),
        hv.Curve((res.time_s, untrusted), t, err, label=f"PCRLB (> {RUNAWAY_LIMIT:g} × range: not predictive)").opts(
            color="#7f7f7f", line_dash="dotted", tools=["hover"]),
    ]).opts(logy=True, title="TRMSE vs PCRLB", legend_position="top_right", responsive=True)


def nees_check(nees, runs, states=7, level=core_track.NEES_LEVEL):
    """'' if a mean NEES is consistent with ``runs`` independent runs of a ``states``-state
    filter, else a warning: outside :func:`core.tracking.montecarlo.nees_band` (the band the
    command line's summary.json flags as ``nees_consistent``)."""
    lo, hi = core_track.nees_band(states, runs, level)
    if nees > hi:
        return (f"**Warning: the filter is overconfident** — mean NEES {nees:.3g} is above "
                f"{hi:.3g}, the {level:.0%} bound for {states} consistent states over {runs} runs: its "
                "covariance claims far less error than it makes; do not quote its σ.")
    if nees < lo:
        return (f"**Note: the filter is underconfident** — mean NEES {nees:.3g} is below {lo:.3g}, "
                f"the {level:.0%} bound: its covariance is larger than its errors.")
    return ""


def summary_text(out):
    """One line of numbers for the tab (markdown)."""
    s = out["res"].summary
    if s["diverged"] is None:  # the final bound predicts nothing there: no share to quote
        lo, hi = s.get("final_error_range_m", (math.nan, math.nan))
        diverged = (f"divergence {s['diverged_rule']} (final errors {lo:.3g} … {hi:.3g} m)")
    else:
        diverged = (f"diverged {100 * s['diverged']:.0f} % (a run diverges when its final error "
                    "exceeds max(5 × final PCRLB, 10 m))")
    parts = [f"**{s['filter']}**, {s['runs']} runs: {diverged}; final TRMSE "
             f"{s['trmse_final_m']:.3g} m vs PCRLB {s['pcrlb_final_m']:.3g} m"]
    warning = ""
    if s.get("nees") is not None:
        dof = int(s.get("nees_dof", 7))
        parts.append(f"mean NEES {s['nees']:.3g} ({dof} states: {dof} if consistent)")
        warning = nees_check(s["nees"], s["runs"], states=dof)
    if s["filter"] == "bank":
        best = max(s["winners"], key=s["winners"].get)
        parts.append(f"final ML winner most often: {best} ({s['winners'][best]} of {s['runs']})")
    if out["breaks"].any():
        share = 100 * out["breaks"].mean()
        parts.append(f"the linearised bound is not predictive on {share:.0f} % of the track "
                     f"(PCRLB > {RUNAWAY_LIMIT:g} × range: far-field runaway along range–strength)")
    if "case" in out and out["case"].name.endswith("seed001-trial"):
        parts.append("the command line's seed001-trial case (`python -m core.track --case "
                     "seed001-trial`), its priors included")
    note = out.get("tracker_note", "")
    return ("; ".join(parts) + "." + (f"\n\n{warning}" if warning else "")
            + (f"\n\n{note}" if note else ""))


def outputs_of(snapshot):
    """The tab's outputs for a snapshot of :data:`READS`: the summary line and the two HoloViews
    overlays (built on a worker thread, :mod:`app.kit.offloop`; drawn on the event loop)."""
    out = SHARED.get(snapshot, _compute)
    return dict(summary=summary_text(out), plan=plan_view(out), error=error_view(out))


def _outputs(scenario: Scenario, shown=ALWAYS):
    """The summary, plan view and error plot, kept current off the event loop: a change of an
    input starts the Monte-Carlo on a worker thread (:class:`app.kit.offloop.Task`), a spinner over
    them meanwhile; a case refused before computing (a track through a station, too many
    steps) is said above them and the last plots stay."""
    problem = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width",
                            css_classes=["w-track-problem"])
    #: Said (under the spinner) until the first track is shown: the first visit computes it
    summary = pn.pane.Markdown("*Computing the track, its bound and the trackers' runs …*",
                               sizing_mode="stretch_width", css_classes=["w-track-summary"])
    plan = pn.pane.HoloViews(None)  # its own size: to scale (a stretched width was not)
    error = pn.pane.HoloViews(None, sizing_mode="stretch_width", height=340)
    # min_height: the spinner over it is seen before the first plots come (it was a ring ~10 px high)
    outputs = pn.Column(summary, plan, error, sizing_mode="stretch_width", min_height=400)
    task = offloop.Task("track", busy=[outputs])
    shown_any = [False]  # whether a track has been shown: what a refusal may say of the plots

    def say(text):
        problem.param.update(object=text, visible=bool(text))

    def not_computed(why):
        # nothing shown yet: say so, not "computing" (it stayed for good) nor "the last track"
        if shown_any[0]:
            say(f"Track not computed: {why}. The plots show the last computed track.")
        else:
            say(f"Track not computed: {why}.")
            summary.object = "*No track computed yet.*"

    def show(shown):
        say("")
        shown_any[0] = True
        summary.object, plan.object, error.object = shown["summary"], shown["plan"], shown["error"]

    def failed(exc):  # e.g. a track outside the sea: said, the last plots stay
        not_computed(str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}")

    def start(*_):
        with task.lock:  # the values as they are when this decides (two watchers may race)
            key = Snapshot.of(scenario, READS)
            try:
                case_of(key.scenario())
            except ValueError as exc:
                task.cancel()
                not_computed(str(exc).rstrip("."))
                return
            task.start(key, partial(outputs_of, key), show, failed)

    scenario.watch_inputs(shown(start), READS)  # hidden, it runs when the tab is shown again
    start()
    return pn.Column(problem, outputs, sizing_mode="stretch_width")


#: The parts whose values :func:`note_text` quotes (the target's moments and depth, the sensor noise).
NOTE_READS = ("target", "sensor")


def note_text(s):
    """The tab's help, quoting the target's moments and the sensor noise it uses: they are set in
    the sidebar's Target and Advanced sections (the help said "set above", and the noise is in
    the collapsed Advanced section on the left)."""
    kind = SENSORS[s.sensor]
    noise = BY_KIND[kind].noise_text(s)  # the kind's sensor part says it (app.state.sensors)
    if kind == "E":
        source = (f"the target's moments P = ({s.Ph:g}, {s.Pv:g}) A·m (sidebar, *Target*) and the "
                  f"sensor noise {noise} (sidebar, *Advanced*)")
    else:
        source = (f"the target's moment m = ({s.mx:g}, {s.my:g}, {s.mz:g}) A·m² (sidebar, *Target*) "
                  f"and the sensor noise {noise} (sidebar, *Advanced*)")
    return (f"A straight track over the design tab's stations at the target depth z = {s.z:g} m, "
            f"with {source}. The PCRLB (Tichavský) is the best achievable position σ along it; the "
            "trackers are run on simulated measurements. Beneath: the snapshot CRLB map (3-D position "
            "σ over N instants at the track's velocity, darker = smaller), dotted white where it "
            f"exceeds {RUNAWAY_LIMIT:.0%} of the range to the nearest station (the linearised bound "
            "does not predict there).")


def track_tab(scenario: Scenario, shown=ALWAYS):
    """The Track tab's layout for a shared :class:`Scenario` (a Panel layout); its outputs are
    built (and first computed) when the tab is first shown. ``shown``: the tab's
    :class:`app.kit.shown.WhenShown` (hidden, the tab computes nothing; it follows the scenario when
    shown again, a spinner over its plots meanwhile)."""
    own = list(scenario.track.names())
    # every number is typed or dragged (a box above its slider in its declared format, app.kit.inputs:
    # a refused text is said, not dropped); the choices are selectors
    numbers = [n for n in own if isinstance(scenario.track.param[n], param.Number)]
    widgets = pn.Column(*[
        number_input(scenario.track, name, css_classes=[f"w-{name}"]) for name in numbers],
        # the choices in one Param (one per choice cost ~20 ms more each to build)
        pn.Param(scenario.track, parameters=[n for n in own if n not in numbers], show_name=False,
                 sizing_mode="stretch_width"),
        sizing_mode="stretch_width", margin=0)
    note = pn.pane.Markdown(note_text(scenario.snapshot(NOTE_READS)), sizing_mode="stretch_width",
                            css_classes=["w-track-note"])
    scenario.watch(shown(lambda *_: setattr(note, "object", note_text(scenario.snapshot(NOTE_READS)))),
                   NOTE_READS)

    def outputs():
        return _outputs(scenario, shown)

    return pn.Row(
        pn.Column(widgets, refusal(scenario, own, "w-message-track"), width=320),
        pn.Column(
            note,
            # lazy: not computed until the tab is first shown (each change of the maps' inputs
            # re-ran the Monte-Carlo here, on a hidden tab: ~100 ms of every slider release).
            # A ParamFunction: pn.panel(lambda: ..., lazy=True) made an ``interactive`` of the
            # zero-argument lambda, which ran it at once, in every new session; its plots were
            # then drawn in the tab's first render, 2-3 s blank with no spinner (issue 25). Now
            # the first render is the inputs and a spinner, and the plots follow.
            pn.param.ParamFunction(outputs, lazy=True, sizing_mode="stretch_width"),
            sizing_mode="stretch_width",
        ),
        sizing_mode="stretch_width",  # stretch_both made Panel override the Tabs' sizing (logged)
    )


#: The Track tab, as the page mounts it (app.kit.tab).
TAB = Tab("track", "Track", reads=READS, banner=True, waits=True,
          view=lambda m: track_tab(m.scenario, m.shown))
