"""The Shape tab's verdict text (app/tabs/shape/shape.py): what each estimator read, against the truth and
the bound, and whether this pass can size the target at all.

A ✓ is given only where it can be trusted: the kind matches the truth *and* the pass is
sizable (:attr:`core.shape.bound.ShapeBound.verdict`, :data:`core.shape.bound.SIZABLE_RULE`:
|model bias| + Z σ of the read that sizes best against 10 % of the main scale). On a pass that cannot size the target no kind or scale gets a ✓ and the text
says why (issue 40, defect 10). Pure functions of the tab's computed output: no physics here.
"""

from __future__ import annotations

import numpy as np

from core.shape.bound import SIZABLE_FRACTION, SIZABLE_RULE
from core.shape.experiment import EULER_FLAG_COND, SETTLE

__all__ = ["ESTIMATORS", "HOW", "no_answer_line", "sizing_text", "verdict_text"]

#: Estimators of the verdict: key of the summary -> label.
ESTIMATORS = {"ukf": "UKF", "nhukf": "NHUKF (Huber)", "fit": "Batch fit (whole pass)"}

#: How the verdict is decided (shown under it).
HOW = (f"*How the verdict is decided*: from the Cramér–Rao σ of the main scale and the batch "
       f"fit's model bias, in the read that sizes best (the span of the 4 dipoles along the axis, "
       f"or their second moment): {SIZABLE_RULE}. Where it says sizable the batch fit sizes ≥ 80 % "
       "of passes within 10 % and 10°, where it says not < 50 % (docs/shape.md, *Sizable*). "
       "The kind must be right and the pass sizable. Only then does a verdict get a ✓.")


def _fmt(v, spec=".3g"):
    return "—" if v is None or not np.isfinite(v) else format(v, spec)


#: An axis is a line: no estimate is more than 90° off it, so a 1σ bound of 90° or more says
#: nothing about the axis (a far pass gave "± 7.6e+03°", issue 46 defect 14).
NO_ANGLE_BOUND_DEG = 90.0


def _angle_bound(deg):
    """The axis's 1σ bound as the text says it: "no bound" where it constrains nothing."""
    if deg is None or not np.isfinite(deg) or deg >= NO_ANGLE_BOUND_DEG:
        return "no bound"
    return f"bound ± {format(deg, '.2g')}°"


def sizing_text(case, b):
    """One paragraph: the bound of the main scale in both reads, the rigid line, and the
    verdict."""
    t = case.target
    limit = SIZABLE_FRACTION * t.main_scale
    rigid = (f", rigid line ± {_fmt(b.rigid_main_scale_m, '.2g')} m"
             if np.isfinite(b.rigid_main_scale_m) else "")
    bounds = (f"span read ± {_fmt(b.main_scale_m, '.2g')} m, second-moment read ± "
              f"{_fmt(b.spread_main_scale_m, '.2g')} m{rigid}")
    if b.sizable:
        return (f"**This pass can size the target**: the main scale's bound (1σ) is {bounds}; the "
                f"{b.sizing} read's is within {100 * SIZABLE_FRACTION:g} % of {t.main_scale:g} m "
                f"(≤ {limit:.2g} m).")
    why = (f"for the {b.sizing} read |model bias| {abs(b.best_bias_m):.2g} m + Z σ = "
           f"{b.margin_m:.2g} m is above {limit:.2g} m ({100 * SIZABLE_FRACTION:g} % of "
           f"{t.main_scale:g} m)")
    if b.verdict == "borderline":
        return (f"**This pass is at the edge of sizing the target**: the main scale's bound (1σ) is "
                f"{bounds}; {why}, though σ itself is below it: the batch fit sizes some passes "
                "but not most there. None is marked right. Pass closer.")
    return (f"**This pass cannot size the target**: the main scale's bound (1σ) is {bounds}; "
            f"{why}. The kinds, "
            "scales and axes below are what the estimators ended with, not a size, and none is marked "
            "right. Pass closer "
            "(the bound against the closest approach is plotted below).")


def no_answer_line(label, d, runs):
    """An estimator with no answer on any pass (core's kind ``"none"``: the batch fit converged
    plausibly on none): say so plainly, with no kind, scale, axis or centroid to read."""
    n = d.get("runs", runs)
    passes = f"none of {n} passes" if n > 1 else "the pass"
    return (f"**{label}**: **no fit converged** ({passes}: each ended unconverged or implausibly "
            "far from the track), so it reads no kind, scale, axis or centroid here.")


def verdict_text(out):
    """The verdict of each estimator against the truth and the bound (markdown)."""
    case, res, b = out["case"], out["res"], out["bound"]
    t, s = case.target, res.summary["filters"]
    runs = res.runs
    what = "cylinder" if t.kind == "line" else "disc"
    hollow = (f", hollow (cavity H_in {t.inner_height:g} m, R_in {t.inner_radius:g} m)"
              if t.inner_height else "")
    update = "one-sample update" if case.lag == 0 else f"seed 003's window update (lag {case.lag})"
    lines = [f"**Truth**: {t.kind} ({what} H {t.height:g} m, R {t.radius:g} m{hollow}, "
             f"{t.positions.shape[0]} cells), main scale {t.main_scale:g} m; closest approach "
             f"**{out['cpa']:.3g} m**; noise σ {case.noise_g:g} nT/m; filters: {update}"
             + (f"; {runs} passes (medians)" if runs > 1 else "") + ".",
             sizing_text(case, b)]
    for name, label in ESTIMATORS.items():
        if name not in s:
            continue
        d = s[name]
        if d["kind"] == "none":  # core's kind when no pass gave an answer (experiment._scores)
            lines.append(no_answer_line(label, d, runs))
            continue
        if d["kind"] == "tie":  # as many passes say line as plane: both, with their scales
            by_kind = d.get("main_scale_by_kind_m", {})
            kind = "line or plane: a tie (" + ", ".join(
                f"{k} {100 * d['kind_share'].get(k, 0.0):.0f} %, {_fmt(by_kind.get(k, float('nan')))} m"
                for k in ("line", "plane")) + ")"
            ok, scale = "?", "—"
        else:
            share = d["kind_share"].get(d["kind"], 1.0)
            kind = d["kind"] + (f" ({100 * share:.0f} % of passes)" if runs > 1 else "")
            if d["kind"] != t.kind:
                ok = "✗ (truth: " + t.kind + ")"
            else:
                ok = "✓" if b.sizable else "(not to be trusted: this pass cannot size the target)"
            scale = f"{_fmt(d['main_scale_m'])} m"
        second = (f", second moment {_fmt(d['spread_scale_m'])} m" if t.kind == "line" and
                  d["kind"] == "line" else "")
        nees = f"centroid NEES {_fmt(d['nees'])}"
        if "nees_band" in d:
            lo, hi = d["nees_band"]
            nees += (f" (99 % band {lo:.2g}–{hi:.2g}: "
                     + ("consistent" if lo <= d["nees"] <= hi else
                        f"its σ is {'optimistic' if d['nees'] > hi else 'pessimistic'} by "
                        f"√({d['nees'] / 3:.3g}) ≈ {np.sqrt(d['nees'] / 3):.2g}×") + ")")
        else:
            nees += " (3 if consistent)"
        lines.append(
            f"**{label}**: **{kind}** {ok}, main scale **{scale}** (span{second}; error "
            f"{_fmt(d['main_scale_error_m'], '.2g')} m), axis {_fmt(d['axis_error_deg'])}° off "
            f"({_angle_bound(b.axis_deg)}), centroid error "
            f"{_fmt(d['centroid_error_m'], '.2g')} m (bound {_fmt(b.centroid_m, '.2g')} m), {nees}.")
    e = s["euler"]
    lines.append(f"**Euler** (point fix of each reading): final error {e['centroid_error_m']:.2g} m, "
                 f"peak after {SETTLE} samples {e['peak_error_m']:.2g} m; G ill-conditioned (> "
                 f"{EULER_FLAG_COND:g}) on {100 * e['flagged_share']:.0f} % of samples.")
    if b.sizable:
        worst = max(s[n]["main_scale_error_m"] for n in ("ukf", "nhukf"))
        if worst > 10 * b.best_main_scale_m:
            lines.append(f"The filters' main-scale errors are over {int(worst / b.best_main_scale_m):,}× "
                         "the bound: noise does not limit them here, the 4-dipole model of a "
                         "continuum and the filters' linearisation do.")
    lines.append(HOW)
    return "\n\n".join(lines)
