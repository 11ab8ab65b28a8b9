"""The Shape tab (seed 003, issue 27): locating and sizing an extended magnetic target from a
moving gradiometer.

``shape_tab(scenario)`` returns the tab's layout (the page builds it when the tab is first shown). Its inputs
are the ``shape_*`` parameters of the shared :class:`app.state.scenario.Scenario` (numbers refused
outside ``ACCEPTED`` with a message, as everywhere; the rules between them are checked by
:func:`case_of`, and said in the tab). It shows

- whether this pass can size the target (the main scale's Cramér–Rao bound in its two reads and
  the rigid line's, :attr:`core.shape.bound.ShapeBound.sizable`) and the verdict of the UKF, the
  NHUKF and the batch fit: line or plane (✓ only when right *and* sizable), main scale, axis and
  centroid errors beside their bounds (:func:`app.tabs.shape.text.verdict_text`);
- plan (x–y) and side (x–z, z down) views: the true outline, the estimated dipoles of every
  pass and the PCA axes of pass 1, the track and its closest approach (:func:`target_view`);
- the position error along the pass for the UKF, the NHUKF and Euler's point fix, with the
  outliers marked (:func:`error_view`);
- the bound against the closest approach, the current pass marked (:func:`bound_view`).

Every number comes from :mod:`core.shape` (``run_case``, ``shape_bound``, ``shape_bound_curve``):
no physics or filter here. The computation runs on a worker thread (the event loop only draws),
one at a time per kernel (``KERNEL_LOCK``), cached per set of inputs.
"""

from __future__ import annotations

from functools import partial

import holoviews as hv
import numpy as np
import panel as pn
import param

from core.shape import Outliers, Pass, Target
from core.shape.targets import CLEARANCE, clearance
from core.shape.bound import SIZABLE_FRACTION, shape_bound_curve
from core.shape.cases import CASES
from core.shape.experiment import EULER_FLAG_COND, SETTLE, Case, run_case
from core.shape.model import LAG

from app.kit import offloop
from app.kit.alerts import alert, with_refusal
from app.kit.cache import KERNEL_LOCK, SHARED
from app.kit.inputs import number_input
from app.kit.tab import Tab
from app.state.scenario import Scenario, Shape, groups, inputs
from app.state.snapshot import Snapshot
from .text import verdict_text

hv.extension("bokeh", logo=False)

#: The parts (app.state.scenario.PARTS) the tab reads: its own.
READS = ("shape",)
#: The tab's inputs.
PARAMS = Shape.names()
#: The filter update: label -> lag of core.shape.experiment.Case (0: one sample).
WINDOWS = {"one sample": 0, "seed 003 window (lag 5)": LAG}
#: The pass (seed 003): start x (m), speed along +x (m/s), rate (Hz), samples: x −40 … +40 m.
START_X, SPEED, RATE, SAMPLES = -40.0, 5.0, 5.0, 81
#: Closest approaches of the bound curve (m): from the target's reach to here.
CURVE_MAX, CURVE_POINTS = 35.0, 14
FILTERS = {"ukf": ("UKF", "#1f77b4"), "nhukf": ("NHUKF (Huber)", "#d62728"),
           "fit": ("Batch fit", "#ff7f0e"), "euler": ("Euler point fix", "#7f7f7f")}
TRUTH = "#000000"
CAPTION = """
*Plan and side views*: the true outline (black) and axis (dashed), the 4 dipoles of every pass
(hover: filter, pass, x, y, z), the PCA axes of pass 1 (a line's u1 over its main scale; a plane's
u1 and u2), the track (green) and its closest point. *Error along the pass*: the centroid of the 4
dipoles against the target's (Euler: its point fix), crosses and dotted lines at the outliers.
The batch fit has one estimate per pass: its square marks its final error. *Bound*: the
Cramér–Rao σ of the main scale (free 4-dipole model in its two reads, span and second moment,
and a rigid line for a cylinder) and of the centroid against the closest approach of a pass in
the same direction; the star is this pass's best read, the black dotted line the true main
scale, the blue dotted line 10 % of it (sizable where |model bias| + 2.5 σ is below it,
borderline where σ alone is: see the verdict).
"""

HELP = """
A target of 0.1 m dipole cells (the **Target** inputs; attitude R = Rz(yaw)·Ry(pitch)·Rx(roll), the
axis is R·e_z) is passed by a gradiometer (5 tensor components, 0.5 m baseline) on a straight
track along +x, from x = −40 to +40 m at 5 m/s, 5 Hz (81 readings), at the lateral offset y and
the height set here (z is down). A UKF and a robust NHUKF (Huber, u = 1.345) fit 4 dipoles with
one common moment (15 states), started from Euler's point fix of the first reading, with seed
003's window update (three lagged readings, lag 5: the paper's method; the one-sample update is
offered for comparison); the PCA of the 4 final dipoles reads the axis, the main scale (a
cylinder's H, a disc's diameter) and the verdict, *line* or *plane*. The batch fit fits the same model to the whole pass at once (Huber,
Levenberg–Marquardt, the gradiometer's array modelled), started from the filters' end states.
The bound is the Cramér–Rao σ of the one-sample 4-dipole model at the
true target (free: 15 states; rigid line: 9): errors far above it come from the model (4 dipoles
for a continuum), not from the noise. See docs/shape.md.
"""


def parse_outliers(text):
    """Platform x positions (m) of the outliers in ``text`` ('−20, −10, 0'; empty: none).

    Raises ValueError naming what was wrong and what is accepted."""
    text = (text or "").replace("−", "-").strip()
    if not text:
        return ()
    out = []
    for part in text.split(","):
        try:
            x = float(part)
        except ValueError:
            raise ValueError(f"outliers: {part.strip()!r} is not a number; write platform x "
                             "positions in m separated by commas, e.g. -20, -10, 0") from None
        if not np.isfinite(x) or not START_X <= x <= -START_X:
            raise ValueError(f"outliers: x = {part.strip()} m is off the pass; the platform runs "
                             f"from x = {START_X:g} to {-START_X:g} m")
        out.append(x)
    if len(out) > 20:
        raise ValueError(f"outliers: at most 20 positions; got {len(out)}")
    return tuple(out)


def values_of(case):
    """The ``shape_*`` values of a :class:`core.shape.experiment.Case` (runs and seed kept)."""
    t, p, o = case.target, case.track, case.outliers
    att = [round(float(np.degrees(a)), 9) for a in t.attitude]
    lag = {v: k for k, v in WINDOWS.items()}
    if case.lag not in lag:
        raise ValueError(f"the tab offers lags {sorted(lag)}; the case has {case.lag}")
    return dict(shape_type="cylinder" if t.kind == "line" else "disc",
                shape_height=float(t.height), shape_radius=float(t.radius),
                shape_inner_height=float(t.inner_height), shape_inner_radius=float(t.inner_radius),
                shape_roll=att[0], shape_pitch=att[1], shape_yaw=att[2],
                shape_mx=float(t.moment[0]), shape_my=float(t.moment[1]), shape_mz=float(t.moment[2]),
                shape_offset=float(p.start[1]), shape_above=float(-p.start[2]),
                shape_noise=float(case.noise_g),
                shape_outliers=", ".join(f"{x:g}" for x in o.at_x),
                shape_outlier_size=float(o.size), shape_window=lag[case.lag])


def _presets():
    out = {}
    for name, (_, rows) in CASES.items():
        main = [r for r in rows if not r.comparison]
        for row in rows:
            v = values_of(row)
            if v in out.values():  # a table's row that is Fig. 4 is the Fig. 4 preset
                continue
            if row.comparison:
                out[f"{name} (one-sample update, for comparison)"] = v
            else:
                out[name if len(main) == 1 else f"{name}: {row.name}"] = v
    return out


#: The paper's cases (core.shape.cases.CASES, one entry a distinct row) as the tab's values.
PRESETS = _presets()


def preset_of(values):
    """The first :data:`PRESETS` name whose values ``values`` (a mapping) holds, or None."""
    for name, preset in PRESETS.items():
        if all(values.get(k) == v for k, v in preset.items()):
            return name
    return None


def key_of(scenario):
    """The tab's inputs as a hashable key (its part's inputs' :class:`app.state.snapshot.Snapshot`)."""
    return Snapshot.of(scenario, inputs(*READS))


def case_of(values):
    """The :class:`core.shape.experiment.Case` of the tab's values (a mapping of ``shape_*``).

    Raises ValueError for values that are each accepted but not together: the type against H
    and R, a cavity that does not fit, a track through (or within :data:`CLEARANCE` of) the
    target, outliers off the pass."""
    v = dict(values)
    H, R = v["shape_height"], v["shape_radius"]
    if (H > R) != (v["shape_type"] == "cylinder"):
        kind = "cylinder (H > R)" if H > R else "disc (H ≤ R)"
        raise ValueError(f"H = {H:g} m and R = {R:g} m make a {kind}, not a {v['shape_type']}: "
                         "change the type or the sizes (seed 003's rule)")
    target = Target(height=H, radius=R, inner_height=v["shape_inner_height"],
                    inner_radius=v["shape_inner_radius"],
                    attitude=tuple(np.radians([v["shape_roll"], v["shape_pitch"], v["shape_yaw"]])),
                    moment=(v["shape_mx"], v["shape_my"], v["shape_mz"]))
    if not np.any(target.moment):
        raise ValueError("the cell moment is zero: the target has no field (A·m²)")
    track = Pass(start=(START_X, float(v["shape_offset"]), -float(v["shape_above"])),
                 velocity=(SPEED, 0.0, 0.0), rate=RATE, samples=SAMPLES)
    near = clearance(target, track)
    if near < CLEARANCE:
        raise ValueError(f"the track passes {near:.2f} m from the target's nearest cell; keep it at "
                         f"least {CLEARANCE:g} m away (lateral offset or height)")
    outliers = Outliers(at_x=parse_outliers(v["shape_outliers"]), size=float(v["shape_outlier_size"]))
    noise = float(v["shape_noise"])
    return Case(name="shape tab", target=target, track=track, outliers=outliers, noise_g=noise,
                noise_b=noise, lag=WINDOWS[v["shape_window"]])


def curve_cpas(target, cpa):
    """Closest approaches (m) of the bound curve: from just outside the target to
    :data:`CURVE_MAX`, with the current pass's own."""
    reach = float(np.max(np.linalg.norm(target.positions - target.centroid, axis=1)))
    lo = reach + CLEARANCE
    return np.unique(np.r_[np.geomspace(lo, max(CURVE_MAX, 2 * lo), CURVE_POINTS), cpa])


def compute(key):
    """Everything the tab shows for the inputs ``key`` (:func:`key_of`), from the one cache
    (app.kit.cache.SHARED): dict with the case, the :class:`core.shape.experiment.CaseResult`, the
    bound at the pass and the curve."""
    return SHARED.get(key, _compute)


def _compute(key):
    v = dict(key.items)
    case = case_of(v)
    with KERNEL_LOCK:  # numba's parallel kernels: one caller at a time (app.kit.cache)
        res = run_case(case, runs=int(v["shape_runs"]), seed=int(v["shape_seed"]),
                       filters=("ukf", "nhukf"))
    cpa = case.track.closest_approach(case.target.centroid)
    cpas = curve_cpas(case.target, cpa)
    with KERNEL_LOCK:
        curve = shape_bound_curve(cpas, case.target, case.track, case.noise_g)
    here = curve[int(np.argmin(np.abs(cpas - cpa)))]
    return dict(case=case, res=res, cpa=cpa, bound=here, cpas=cpas, curve=curve)


#: Farthest (m) the track's closest point may be from the target's box and still be in the views.
NEAR_TRACK = 4.0


def _window(out):
    """((x0, x1), (y0, y1), (z0, z1)) of the views (m), square: the target with a 1 m margin,
    and the track's closest point if it lies within :data:`NEAR_TRACK` of it (a far track would
    shrink the target to a dot; the title then says where the track is)."""
    case = out["case"]
    t, p = case.target, case.track
    lo, hi = t.positions.min(axis=0), t.positions.max(axis=0)
    near = p.positions[np.argmin(np.linalg.norm(p.positions - t.centroid, axis=1))]
    if np.all(near >= lo - NEAR_TRACK) and np.all(near <= hi + NEAR_TRACK):
        lo, hi = np.minimum(lo, near), np.maximum(hi, near)
    lo, hi = lo - 1.0, hi + 1.0
    c, half = (lo + hi) / 2, (hi - lo).max() / 2
    return [(float(m - half), float(m + half)) for m in c]


def target_view(out, plane="xy"):
    """Plan (``"xy"``) or side (``"xz"``, depth down) view (m): the true outline and axis, the
    dipoles of every pass, the PCA axes of pass 1, the track and its closest point."""
    case, res = out["case"], out["res"]
    t = case.target
    i, j = (0, 1) if plane == "xy" else (0, 2)
    names = "xyz"
    a = hv.Dimension(names[i], unit="m")
    b = hv.Dimension(names[j], label="z (down)" if j == 2 else names[j], unit="m")
    layers = [hv.Path([ln[:, [i, j]] for ln in t.outline()], kdims=[a, b], label="true outline").opts(
        color=TRUTH, line_width=1.5)]
    ax = t.centroid + np.outer([-0.5, 0.5], t.axis) * t.main_scale
    layers.append(hv.Curve(ax[:, [i, j]], a, b, label="true axis").opts(
        color=TRUTH, line_dash="dashed", line_width=1))
    for name in ("ukf", "nhukf", "fit"):
        label, color = FILTERS[name]
        label = label.split(" (")[0]  # short: the legend fits under a half-width plot
        dip = res.dipoles[name]  # (R, N, 3)
        run = np.repeat(np.arange(1, dip.shape[0] + 1), dip.shape[1])
        flat = dip.reshape(-1, 3)
        layers.append(hv.Points(
            {"a": flat[:, i], "b": flat[:, j], "x": flat[:, 0], "y": flat[:, 1], "z": flat[:, 2],
             "pass": run, "filter": np.full(run.shape, label)},
            kdims=[hv.Dimension("a", label=a.label, unit="m"), hv.Dimension("b", label=b.label, unit="m")],
            vdims=[hv.Dimension("filter"), hv.Dimension("pass"), hv.Dimension("x", unit="m"),
                   hv.Dimension("y", unit="m"), hv.Dimension("z", unit="m")],
            label=f"{label} dipoles").opts(color=color, size=9, alpha=0.8, tools=["hover"]))
        f = res.final[name]
        c, L = f["centroid"][0], float(f["main_scale_m"][0])
        for k in ((0,) if str(f["kind"][0]) == "line" else (0, 1)):
            seg = c + np.outer([-0.5, 0.5], f["axes"][0][:, k]) * L
            layers.append(hv.Curve(seg[:, [i, j]], a, b, label=f"{label} axes").opts(
                color=color, line_width=3, alpha=0.7))
    pos = case.track.positions
    k = int(np.argmin(np.linalg.norm(pos - t.centroid, axis=1)))
    layers.append(hv.Curve(pos[:, [i, j]], a, b, label="track").opts(color="#2ca02c", line_width=2))
    layers.append(hv.Points(
        {"a": pos[[k], i], "b": pos[[k], j], "cpa": [out["cpa"]]},
        kdims=[hv.Dimension("a", label=a.label, unit="m"), hv.Dimension("b", label=b.label, unit="m")],
        vdims=[hv.Dimension("cpa", label="closest approach", unit="m")],
        label="closest point").opts(color="#2ca02c", marker="triangle", size=12,
                                                 tools=["hover"]))
    w = _window(out)
    title = "Plan (x–y)" if plane == "xy" else "Side (x–z)"
    if not w[j][0] <= pos[k, j] <= w[j][1]:  # off the view: said in the title
        title += f"; track {names[j]} = {pos[k, j]:g} m".replace("-", "−")
    return hv.Overlay(layers).opts(
        title=title, aspect="equal", xlim=w[i], ylim=w[j], invert_yaxis=j == 2,
        legend_position="bottom", legend_cols=2, responsive=True, show_legend=plane == "xy")


def error_view(out):
    """Position error (m, log) along the pass (platform x, m) of each filter (median over the
    passes), the outliers marked."""
    res = out["res"]
    x = hv.Dimension("platform_x", label="platform x", unit="m")
    e = hv.Dimension("error", label="position error", unit="m")
    layers = []
    for name in ("ukf", "nhukf", "euler"):
        label, color = FILTERS[name]
        with np.errstate(invalid="ignore"):
            err = np.nanmedian(res.errors[name], axis=0) if res.runs > 1 else res.errors[name][0]
        layers.append(hv.Curve((res.platform_x, err), x, e, label=label).opts(
            color=color, line_width=2 if name != "euler" else 1, tools=["hover"]))
        if res.outlier_samples:
            k = list(res.outlier_samples)
            layers.append(hv.Scatter((res.platform_x[k], err[k]), x, e, label="outlier samples").opts(
                color="black", marker="x", size=14, line_width=2, tools=["hover"]))
    if "fit" in res.errors:  # one estimate from the whole pass: a marker at its end
        label, color = FILTERS["fit"]
        layers.append(hv.Scatter(([float(res.platform_x[-1])], [float(np.median(res.errors["fit"]))]),
                                 x, e, label=f"{label} (whole pass)").opts(
            color=color, marker="square", size=12, tools=["hover"]))
    for k in res.outlier_samples:
        layers.append(hv.VLine(float(res.platform_x[k])).opts(color="black", line_dash="dotted",
                                                               line_width=1))
    runs = "" if res.runs == 1 else f", median of {res.runs} passes"
    return hv.Overlay(layers).opts(
        title=f"Error along the pass{runs}", logy=True, legend_position="bottom", legend_cols=3,
        responsive=True)


def bound_view(out):
    """The bound's σ (m, log) against the closest approach (m, log), the current pass marked."""
    cpas, curve, b = out["cpas"], out["curve"], out["bound"]
    x = hv.Dimension("cpa", label="closest approach", unit="m")
    y = hv.Dimension("sigma", label="1σ bound", unit="m")
    layers = [hv.Curve((cpas, [c.main_scale_m for c in curve]), x, y, label="main scale, span read").opts(
        color="#9467bd", line_width=2, tools=["hover"])]
    spread = np.array([c.spread_main_scale_m for c in curve])
    if out["case"].target.kind == "line":  # a disc's two reads are one
        layers.append(hv.Curve((cpas, spread), x, y, label="main scale, second-moment read").opts(
            color="#17becf", line_width=2, tools=["hover"]))
    limit = SIZABLE_FRACTION * out["case"].target.main_scale
    layers.append(hv.HLine(limit).opts(color="#17becf", line_dash="dotted", line_width=1))
    rigid = np.array([c.rigid_main_scale_m for c in curve])
    if np.isfinite(rigid).all():
        layers.append(hv.Curve((cpas, rigid), x, y, label="main scale (rigid line, 9)").opts(
            color="#9467bd", line_dash="dashed", tools=["hover"]))
    layers.append(hv.Curve((cpas, [c.centroid_m for c in curve]), x, y, label="centroid (15 states)").opts(
        color="#8c564b", line_width=2, tools=["hover"]))
    t = out["case"].target
    layers.append(hv.HLine(t.main_scale).opts(color=TRUTH, line_dash="dotted", line_width=1))
    layers.append(hv.Scatter(([out["cpa"]], [b.best_main_scale_m]), x, y, label="this pass").opts(
        color="black", marker="star", size=16, tools=["hover"]))
    return hv.Overlay(layers).opts(
        title="Bound vs closest approach", logx=True, logy=True, legend_position="bottom",
        legend_cols=2, responsive=True)


def views(key):
    """The tab's outputs for inputs ``key``: dict of the verdict markdown and the four
    HoloViews overlays (built on the worker thread; drawn on the event loop)."""
    out = compute(key)
    return dict(verdict=verdict_text(out), plan=target_view(out, "xy"), side=target_view(out, "xz"),
                error=error_view(out), bound=bound_view(out))


def _input(scenario, name):
    """A number (a box and a slider, in its declared format) or a choice or text, by the
    parameter's type."""
    p = scenario.shape.param[name]
    if isinstance(p, param.Number):
        column = number_input(scenario.shape, name, css_classes=[f"w-{name}"])
    else:
        cls = pn.widgets.TextInput if isinstance(p, param.String) else pn.widgets.Select
        w = cls.from_param(p, css_classes=[f"w-{name}"], sizing_mode="stretch_width")
        column = pn.Column(w, margin=0, sizing_mode="stretch_width")
    return with_refusal(scenario, column, [name], "w-message-shape")


def _inputs(scenario):
    preset = pn.widgets.Select(name="Paper case (seed 003)", options=["(custom)", *PRESETS],
                               value=preset_of(scenario.values(READS)) or "(custom)",
                               css_classes=["w-shape-preset"], sizing_mode="stretch_width")

    def chosen(event):
        if event.new in PRESETS:
            scenario.update(PRESETS[event.new])

    def follow(*_):
        preset.value = preset_of(scenario.values(READS)) or "(custom)"

    preset.param.watch(chosen, ["value"])
    scenario.watch(follow, READS)
    cards = [pn.Card(*[_input(scenario, n) for n in names], title=title, collapsed=False,
                     sizing_mode="stretch_width") for title, names in groups(PARAMS)]
    return pn.Column(preset, *cards, width=300)


def _build(scenario):
    """The tab's layout; starts its first computation."""
    problem = pn.pane.HTML("", visible=False, sizing_mode="stretch_width", css_classes=["w-shape-problem"])
    verdict = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["w-shape-verdict"])
    plan = pn.pane.HoloViews(None, height=500, sizing_mode="stretch_width")
    side = pn.pane.HoloViews(None, height=500, sizing_mode="stretch_width")
    error = pn.pane.HoloViews(None, height=380, sizing_mode="stretch_width")
    bound = pn.pane.HoloViews(None, height=380, sizing_mode="stretch_width")
    outputs = pn.Column(verdict, pn.Row(plan, side, sizing_mode="stretch_width"),
                        pn.Row(error, bound, sizing_mode="stretch_width"),
                        pn.pane.Markdown(CAPTION + HELP, sizing_mode="stretch_width"),
                        sizing_mode="stretch_width")
    task = offloop.Task("shape", busy=[outputs])  # the worker threads, the spinner over the plots

    def say(text):
        problem.param.update(object=alert(text, "warning") if text else "", visible=bool(text))

    def show(shown):
        say("")
        verdict.object = shown["verdict"]
        plan.object, side.object = shown["plan"], shown["side"]
        error.object, bound.object = shown["error"], shown["bound"]

    def failed(exc):  # said in the tab, and the plots kept
        say(f"Not computed: {type(exc).__name__}: {exc}")

    def start(*_):
        with task.lock:  # the values as they are when this decides (two watchers may race)
            key = key_of(scenario)
            try:
                case_of(dict(key.items))
            except ValueError as exc:  # each value accepted, not together: said, last plots stay
                say(f"Not computed: {exc}. The plots show the last computed pass.")
                task.cancel()
                return
            task.start(key, partial(views, key), show, failed)

    scenario.watch(start, READS)
    start()
    return _inputs(scenario), pn.Column(problem, outputs, sizing_mode="stretch_width")


def shape_parts(scenario: Scenario):
    """The Shape tab's (inputs, results) for a shared :class:`Scenario` (the page puts the inputs
    in its sidebar, and builds both when the tab is first shown: app.page.first_visit);
    starts its first computation."""
    return _build(scenario)


def shape_tab(scenario: Scenario):
    """The Shape tab as one layout: its inputs beside its results (:func:`shape_parts`)."""
    inputs, outputs = _build(scenario)
    return pn.Row(inputs, outputs, sizing_mode="stretch_width")


#: The Shape tab, as the page mounts it (app.kit.tab): its inputs in the sidebar.
TAB = Tab("shape", "Shape", reads=tuple(Shape.names()), sidebar=True, view=lambda m: shape_parts(m.scenario))
