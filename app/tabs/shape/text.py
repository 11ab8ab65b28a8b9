"""The Shape tab's verdict text (app/tabs/shape/shape.py): what each estimator read, against the truth and
the bound, and whether this pass can size the target at all.

A ✓ is given only where it can be trusted: the kind matches the truth *and* the pass is
sizable (:attr:`core.shape.bound.ShapeBound.sizable`: the read that sizes best has σ ≤ 10 % of
the main scale). On a pass that cannot size the target no kind or scale gets a ✓ and the text
says why (issue 40, defect 10). Pure functions of the tab's computed output: no physics here.
"""

from __future__ import annotations

import numpy as np

from core.shape.bound import SIZABLE_FRACTION
from core.shape.experiment import EULER_FLAG_COND, SETTLE

__all__ = ["ESTIMATORS", "HOW", "sizing_text", "verdict_text"]

#: Estimators of the verdict: key of the summary -> label.
ESTIMATORS = {"ukf": "UKF", "nhukf": "NHUKF (Huber)", "fit": "Batch fit (whole pass)"}

#: How the verdict is decided (shown under it).
HOW = (f"*How the verdict is decided*: a pass can size the target when the Cramér–Rao σ of the "
       f"main scale, in the read that sizes best (the span of the 4 dipoles along the axis, or "
       f"their second moment), is at most {100 * SIZABLE_FRACTION:g} % of the true main scale. "
       "Checked against the Monte-Carlo of the filters and the batch fit (`python -m core.shape "
       "--cpa-sweep`): where it holds they size the target within 10 %, where it does not their "
       "scales and axes scatter. Only then does a verdict get a ✓.")


def _fmt(v, spec=".3g"):
    return "—" if v is None or not np.isfinite(v) else format(v, spec)


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
    return (f"**This pass cannot size the target**: the main scale's bound (1σ) is {bounds}, all "
            f"above {limit:.2g} m ({100 * SIZABLE_FRACTION:g} % of {t.main_scale:g} m). The kinds, "
            "scales and axes below are what the estimators ended with, not a size, and none is marked "
            "right. Pass closer "
            "(the bound against the closest approach is plotted below).")


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
            f"(bound ± {_fmt(b.axis_deg, '.2g')}°), centroid error "
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
