"""Seed 003 (locating and sizing an extended magnetic target with a moving gradiometer): the
report section.

:func:`numbers` recomputes everything from :mod:`core.shape`; :func:`section` turns it into
markdown for ``python -m paper``. ``python -m paper.shape`` prints the section.
"""

from __future__ import annotations

import numpy as np

from core.shape import bound as bd
from core.shape import experiment as ex
from core.shape import model as md
from core.shape.cases import CASES, FIG5_OUTLIERS, TABLE_LAG
from core.shape.pca import DISC_FACTOR, PLANE_RATIO
from core.shape.targets import Target, attitude_matrix
from core.tracking import unscented as uk

#: Monte-Carlo passes per figure case, and per table row.
FIG_RUNS = 40
TABLE_RUNS = 10
SEED = 3
#: The spec's quoted main-scale bounds of the second-moment read with the cylinder's axis along
#: body x (§11): closest approach (m) -> σ (m).
SPEC_FIGURES = ((float(np.sqrt(50.0)), 0.0043), (15.0, 0.26), (30.0, 17.0))
#: Relative agreement that counts as reproducing them: they are printed to 2 digits (17 m is
#: ±3 % by rounding alone).
SPEC_RTOL = 0.05
#: Closest approaches of the bound's table (m); √50 is seed 003's pass, 10√2 its pass at
#: twice the distance (offset 10 m, 10 m above).
BOUND_CPA = (5.0, float(np.sqrt(50.0)), 10.0, float(10 * np.sqrt(2.0)), 15.0, 20.0, 30.0)
FILTERS = ("euler", "ukf", "nhukf", "fit")
#: Estimators with a track (the fit has one estimate per pass).
TRACKED = ("euler", "ukf", "nhukf")


def body_x_target():
    """Seed 003's cylinder with its axis along body x (R e_x of its attitude), the orientation of
    the spec's quoted figures: the attitude R · Ry(π/2) as roll, pitch, yaw."""
    R = attitude_matrix(*Target().attitude) @ np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])
    return Target(attitude=(float(np.arctan2(R[2, 1], R[2, 2])), float(-np.arcsin(R[2, 0])),
                            float(np.arctan2(R[1, 0], R[0, 0]))))


def _row(res):
    s = res.summary["filters"]
    out = {}
    for name in FILTERS:
        f = dict(s[name])
        err = res.errors[name]
        f["centroid_error_p90_m"] = float(np.nanpercentile(err[:, -1], 90))
        f.setdefault("peak_error_m", None)
        if name in res.final:
            f["main_scale_p10_p90_m"] = [float(v) for v in np.percentile(res.final[name]["main_scale_m"], [10, 90])]
            f["axis_error_p90_deg"] = float(np.percentile(res.final[name]["axis_error_deg"], 90))
            f["axis_over_45_share"] = float(np.mean(res.final[name]["axis_error_deg"] > 45.0))
        out[name] = f
    return out


def numbers(fig_runs=FIG_RUNS, table_runs=TABLE_RUNS):
    """Every number of the section, as a dict (recomputed; ~1 min with the defaults). Each case
    runs with its own update (core.shape.cases: seed 003's window), as ``python -m core.shape``
    does; Figs. 4 and 5 also with the one-sample update, their comparison rows."""
    out = {"fig": {}, "one_sample": {}, "tables": {}, "fig_runs": fig_runs, "table_runs": table_runs}
    for key in ("seed003-fig4", "seed003-fig5"):
        for row in CASES[key][1]:
            res = ex.run_case(row, runs=fig_runs, seed=SEED)
            d = _row(res)
            d["lag"] = row.lag
            hit = res.outlier_samples
            d["outlier_samples"] = hit
            if hit:  # error at the outlier samples, median over runs
                d["at_outliers_m"] = {n: [float(np.nanmedian(res.errors[n][:, k])) for k in hit]
                                      for n in TRACKED}
            out["one_sample" if row.comparison else "fig"][key] = d
    for key in ("seed003-table1", "seed003-table2", "seed003-table3", "seed003-table4", "seed003-table5"):
        desc, rows = CASES[key]
        out["tables"][key] = {"description": desc, "rows": []}
        for case in rows:
            res = ex.run_case(case, runs=table_runs, seed=SEED)
            out["tables"][key]["rows"].append({"label": case.name, "truth_scale_m": case.target.main_scale,
                                               "truth_kind": case.target.kind, "lag": case.lag,
                                               "filters": _row(res)})
    out["bound"] = [b.to_dict() for b in bd.shape_bound_curve(BOUND_CPA)]
    out["bound_body_x"] = [b.to_dict() for b in bd.shape_bound_curve([c for c, _ in SPEC_FIGURES],
                                                                     body_x_target())]
    return out


def _spec_sentence(n):
    """Whether the spec's quoted figures are reproduced (computed, not typed)."""
    got = [r["spread_main_scale_m"] for r in n["bound_body_x"]]
    ok = all(abs(g / v - 1) <= SPEC_RTOL for g, (_, v) in zip(got, SPEC_FIGURES))
    figs = ", ".join(f"{v:g} m at {c:.3g} m" for c, v in SPEC_FIGURES)
    ours = ", ".join(f"{g:.2g} m" for g in got)
    return (f"**The spec's main-scale figures ({figs}) are "
            + ("reproduced" if ok else "not reproduced")
            + f"** by the second-moment read with the cylinder's axis along body x ({ours}, within "
            f"{100 * SPEC_RTOL:g} %); at seed 003's attitude (axis along body z) the same read gives "
            "the column above. ")


def _m(v, nd=3):
    return "—" if v is None or not np.isfinite(v) else f"{v:.{nd}f}"


def _small(v, nd=3):
    """As :func:`_m`, but two significant digits where fixed decimals would print 0.0…: the batch
    fit's centroid and axis errors are below them."""
    if v is None or not np.isfinite(v) or abs(v) >= 10.0**-nd * 10 or v == 0:
        return _m(v, nd)
    return f"{v:.2g}"


def section(nums=None):
    """The markdown section of seed 003 (a string; computes :func:`numbers` if not given)."""
    n = numbers() if nums is None else nums
    L = []
    w = L.append
    f4, f5 = n["fig"]["seed003-fig4"], n["fig"]["seed003-fig5"]
    lag, one = f4["nhukf"], n["one_sample"]["seed003-fig4"]["nhukf"]
    w("## Seed 003: locating and sizing an extended magnetic target (UKF, NHUKF, PCA shape)\n")
    w("Seed 003 (spec §11) passes an AUV carrying a gradient-tensor array (0.5 m baseline, 5 Hz, "
      "5 m/s, from (−40, 5, −5) m; closest approach √50 = 7.07 m) by a cylinder (H 3 m, R 0.5 m, "
      "roll/pitch/yaw π/6, π/4, π/3) built from 0.1 m cells of (−3, 1, 5) A·m² (2400 cells, "
      "|M| = 1.42e4 A·m²), tracks it with 4 dipoles of one common moment (15 states) in a UKF "
      "and a Huber-robust UKF (NHUKF), and reads size, axis and type from the PCA of the 4 "
      "dipoles. Reproduced with `python -m core.shape` (`core/shape/`, `core/tracking/unscented.py`; "
      "notes in `docs/shape.md`).\n")
    w("**Reproduced.** The system as the text describes it (pass, target, sensor, 15-state "
      "model, UKF, NHUKF with Huber's u, PCA main scale and line / plane verdict) and the "
      "experiments of Figs. 4 and 5 and Tables 1–5 (our rows), each run by "
      "`python -m core.shape --case …` with the same update as here: the paper's lagged window "
      f"(n = {TABLE_LAG}, `core/shape/cases.py`), and for the figures the one-sample update "
      "beside it for comparison.\n")
    w("**Assumed where the text is lost.** Noise 0.01 nT/m per tensor component and 0.01 nT per "
      "field component; the truth is the array's magnetometer differences, the filters' model "
      "the point tensor; attitude R = Rz(yaw)·Ry(pitch)·Rx(roll) with the body axis z; UKF "
      f"sigma points α = {uk.ALPHA:g}, β = {uk.BETA:g}, κ = {uk.KAPPA:g}; Huber u = {uk.HUBER_U}, "
      "residuals whitened by R (eq. (12): prior residual zero); start: Euler's point fix "
      "r = −3 G⁻¹ B of the first reading, its moment from the field, the 4 dipoles on a "
      f"tetrahedron of radius {md.START_SPREAD:g} m about it (never one point: rank 6), prior σ "
      f"{md.P0_POSITION:g} m and {100 * md.P0_MOMENT_REL:g} % of the moment; random walk "
      f"{md.Q_POSITION:g} m², {md.Q_MOMENT:g} (A·m²)² per step; "
      f"the lagged window (eq. (15)) with n = {md.LAG}. Disc diameter (eq. (22) lost): "
      f"{DISC_FACTOR:.3f} × the square's diagonal (the mean of the two coverings of eqs. (19)–(20)); "
      f"verdict plane if λ2/λ1 ≥ {PLANE_RATIO:g}. Outliers (Fig. 5): +{FIG5_OUTLIERS.size:g} σ on "
      "all five components at platform x = −20, −10, 0 m. Table rows: the paper's are lost; ours "
      "vary one property each (listed below).\n")

    w(f"### Figs. 4 and 5 ({n.get('fig_runs', FIG_RUNS)} Monte-Carlo passes "
      "each; medians, 90th percentile in brackets)\n")
    w("| case | update | filter | final centroid error (m) | peak error after 10 samples (m) "
      "| main scale (m; truth 3) | axis error (°) | verdict | centroid NEES (3 dof) |")
    w("|---|---|---|---|---|---|---|---|---|")
    for key, label in (("seed003-fig4", "Fig. 4"), ("seed003-fig5", "Fig. 5")):
        for part, upd in (("fig", f"window (lag {TABLE_LAG})"), ("one_sample", "one sample (comparison)")):
            d = n[part][key]
            for name in FILTERS:
                v = d[name]
                shape = (f"{_m(v['main_scale_m'], 2)} ({_m(v['main_scale_p10_p90_m'][0], 2)}–"
                         f"{_m(v['main_scale_p10_p90_m'][1], 2)}) | {_small(v['axis_error_deg'], 1)} "
                         f"({_small(v['axis_error_p90_deg'], 1)}) | {v['kind']} "
                         f"({100 * max(v['kind_share'].values()):.0f} %) "
                         f"| {v['nees']:.2g}") if "kind" in v else "— | — | — | —"
                w(f"| {label} | {upd} | {name.upper()} | {_small(v['centroid_error_m'])} "
                  f"({_small(v['centroid_error_p90_m'])}) | {_m(v['peak_error_m'])} | {shape} |")
    w("")
    for part, upd in (("fig", "window"), ("one_sample", "one-sample update")):
        at = n[part]["seed003-fig5"]["at_outliers_m"]
        w(f"At Fig. 5's outlier samples ({upd}) the median position error is "
          + "; ".join(f"{nm.upper()} " + ", ".join(_m(e) for e in at[nm]) + " m" for nm in TRACKED)
          + " (x = −20, −10, 0 m).\n")
    o5 = n["one_sample"]["seed003-fig5"]["nhukf"]
    w(f"Locating holds up: both filters end a few centimetres from the centroid (median "
      f"{_m(f4['ukf']['centroid_error_m'])} / {_m(lag['centroid_error_m'])} m, the paper's < 0.1 m) "
      f"and far better than Euler's point fix ({_m(f4['euler']['centroid_error_m'])} m, a point "
      "for an extended body). Under outliers the NHUKF's peak error is "
      f"{_m(f5['nhukf']['peak_error_m'], 2)} m against the UKF's {_m(f5['ukf']['peak_error_m'], 2)} m "
      f"and Euler's {_m(f5['euler']['peak_error_m'], 2)} m"
      + (" (the paper's claim holds in direction)" if f5['nhukf']['peak_error_m'] < f5['ukf']['peak_error_m']
         else " (the paper's claim fails)")
      + f"; its shape after Fig. 5's pass: {f5['nhukf']['kind']}, main scale "
      f"{_m(f5['nhukf']['main_scale_m'], 2)} m, axis {f5['nhukf']['axis_error_deg']:.1f}° (UKF: "
      f"{f5['ukf']['kind']}, axis {f5['ukf']['axis_error_deg']:.0f}°). "
      f"Seed 003's window (15 rows an update) sizes Fig. 4 well — NHUKF main scale "
      f"{_m(lag['main_scale_m'], 2)} m, axis {lag['axis_error_deg']:.1f}°, "
      f"line in {100 * lag['kind_share'].get('line', 0):.0f} % — but counts every sample three times, "
      f"so its covariance is optimistic (centroid NEES {lag['nees']:.3g} against 3). "
      "**The honest one-sample update is fragile**: the 15 states are read from 5 components a "
      f"sample, and the NHUKF's final axis is off by more than 45° in "
      f"{100 * one['axis_over_45_share']:.0f} % of Fig. 4's passes (median {one['axis_error_deg']:.0f}°, "
      f"verdict right in {100 * one['kind_share'].get('line', 0):.0f} %); with Fig. 5's outliers its "
      f"axis is {o5['axis_error_deg']:.0f}° off. (The one-sample filter is inconsistent here too, "
      "from the model mismatch, and consistent on a truth that is itself 4 dipoles: "
      "`tests/test_shape.py`.) Every case therefore runs the paper's window.\n")
    fit4, fit5 = f4["fit"], f5["fit"]
    w("**Beyond the paper: the batch fit** (`core/shape/fit.py`). A survey is processed after the "
      "pass, so the 4-dipole model can be fitted to every reading at once, each once: Huber's "
      "M-estimate by Levenberg–Marquardt, the 0.5 m array modelled, started from the filters' end "
      "states, its covariance the inverse Fisher information times the residuals' variance "
      f"factor. Fig. 4: axis {fit4['axis_error_deg']:.3f}°, main scale {_m(fit4['main_scale_m'], 3)} m "
      f"(error {_m(fit4['main_scale_error_m'], 3)} m), centroid {_m(fit4['centroid_error_m'], 4)} m, "
      f"NEES {fit4['nees']:.2g} (99 % band {fit4['nees_band'][0]:.2g}–{fit4['nees_band'][1]:.2g}); "
      f"Fig. 5: axis {fit5['axis_error_deg']:.3f}°, main scale {_m(fit5['main_scale_m'], 3)} m, NEES "
      f"{fit5['nees']:.2g}: the paper's < 1–2° axis, which neither filter reaches, and a covariance "
      "that is not optimistic. The fit's row is the same whichever update the filters that start "
      "it used.\n")
    w(f"### Tables 1–5 (our rows; {n.get('table_runs', TABLE_RUNS)} passes per row, lagged window "
      f"n = {TABLE_LAG}, medians; the main scale is the median over the runs of the majority "
      "verdict, — on a tie)\n")
    w("| table | row | truth | UKF scale (m) / axis (°) / verdict | NHUKF scale (m) / axis (°) / verdict "
      "| batch fit scale (m) / axis (°) / verdict | NHUKF centroid error (m) |")
    w("|---|---|---|---|---|---|---|")
    for key, t in n["tables"].items():
        for r in t["rows"]:
            cell = lambda v: f"{_m(v['main_scale_m'], 2)} / {_small(v['axis_error_deg'], 1)} / {v['kind']}"
            f = r["filters"]
            w(f"| {key[-1]} | {r['label']} | {r['truth_scale_m']:g} m, {r['truth_kind']} | {cell(f['ukf'])} "
              f"| {cell(f['nhukf'])} | {cell(f['fit'])} | {_m(f['nhukf']['centroid_error_m'])} |")
    w("")

    wrong = [f"{k[-1]}: {r['label']}" for k, t in n["tables"].items() for r in t["rows"]
             if r["filters"]["nhukf"]["kind"] != r["truth_kind"]]
    disc = [r["filters"]["nhukf"]["main_scale_m"] - r["truth_scale_m"] for t in n["tables"].values()
            for r in t["rows"] if r["truth_kind"] == "plane" and r["filters"]["nhukf"]["kind"] == "plane"]
    w("Where the reading fails (NHUKF): the verdict is wrong for "
      + ("; ".join(wrong) if wrong else "no row")
      + (f"; the discs' diameters are off by {min(disc):+.2f} to {max(disc):+.2f} m under our reading "
         "of the lost eq. (22)." if disc else ".") + "\n")
    b = n["bound"]
    w("### What the bound says\n")
    w("Cramér–Rao bound of the one-sample 15-state model at the target's own 4-dipole "
      "representation (dipoles at the centres of 4 equal segments of the axis, M/4 each), σ = "
      "0.01 nT/m, the same pass moved to each closest approach (`core.shape.bound`). The main "
      "scale has two reads of the 4 dipoles: their span along the axis (eq. (18)) and their "
      "second moment along it (√(12 λ1 N/(N+1))); beside them the bound if the 4 dipoles were a "
      "rigid evenly spaced line (9 parameters), the position bound of a point dipole of the same "
      f"total moment (6 parameters), and the verdict ({bd.SIZABLE_RULE}; \"sizable\" below is "
      "yes only for sizable):\n")
    w("| closest approach (m) | centroid (m) | main scale, span read (m) | main scale, second moment (m) "
      "| axis (°) | rigid line: main scale (m) | axis (°) | point dipole: position (m) | sizable |")
    w("|---|---|---|---|---|---|---|---|---|")
    for r in b:
        w(f"| {r['closest_approach_m']:.2f} | {r['centroid_m']:.2g} | {r['main_scale_m']:.2g} | "
          f"{r['spread_main_scale_m']:.2g} | {r['axis_deg']:.2g} | {r['rigid_main_scale_m']:.2g} | "
          f"{r['rigid_axis_deg']:.2g} | {r['point_position_m']:.2g} | {'yes' if r['sizable'] else 'no'} |")
    b7 = next(r for r in b if abs(r["closest_approach_m"] - np.sqrt(50)) < 1e-6)
    b14 = next(r for r in b if abs(r["closest_approach_m"] - 10 * np.sqrt(2)) < 1e-6)
    b15 = next(r for r in b if abs(r["closest_approach_m"] - 15) < 1e-6)
    b30 = next(r for r in b if abs(r["closest_approach_m"] - 30) < 1e-6)
    slope = np.log(b30["main_scale_m"] / b15["main_scale_m"]) / np.log(2.0)
    sslope = np.log(b30["spread_main_scale_m"] / b15["spread_main_scale_m"]) / np.log(2.0)
    rslope = np.log(b30["rigid_main_scale_m"] / b15["rigid_main_scale_m"]) / np.log(2.0)
    w("")
    w(f"On seed 003's pass noise allows the main scale to {b7['main_scale_m'] * 1e3:.1f} mm (span) "
      f"or {b7['spread_main_scale_m'] * 1e3:.1f} mm (second moment), the centroid to "
      f"{b7['centroid_m'] * 1e3:.2f} mm and a point dipole's position to "
      f"{b7['point_position_m'] * 1e6:.0f} µm, while the NHUKF's median errors are "
      f"{_m(lag['main_scale_error_m'], 2)} m (main scale, lagged window; "
      f"{_m(one['main_scale_error_m'], 2)} m one-sample) and {_m(lag['centroid_error_m'])} m "
      f"(centroid), and the batch fit's {_m(fit4['main_scale_error_m'], 2)} m: the paper's "
      "0.1–0.3 m are model mismatch (4 dipoles for 2400 cells), not noise. Shape is a near-field "
      f"capability: between 15 and 30 m the span read's bound grows as CPA^{slope:.1f} (it hangs on "
      "the end dipoles' spacing, a fourth-order term of the field), the second moment's as "
      f"CPA^{sslope:.1f}, the rigid line's as CPA^{rslope:.1f}. **How the verdict is decided**: "
      f"by the read that sizes best, not the span alone. At twice seed 003's distance (offset 10 m, "
      f"10 m above, {b14['closest_approach_m']:.1f} m) the span read's σ is "
      f"{b14['main_scale_m']:.2g} m but the second moment's {b14['spread_main_scale_m'] * 100:.1f} cm: "
      "sizable, and the filters and the fit do size the cylinder there; the rule is checked "
      "against the batch fit's Monte-Carlo over closest approaches in steps of 0.5 m, for a "
      "cylinder and a disc (`tests/test_shape_sizable_sweep.py`; "
      "`python -m core.shape --cpa-sweep` draws the curve and answers how close the pass must "
      "be). " + _spec_sentence(n) + "\n")
    return "\n".join(L)


if __name__ == "__main__":
    print(section())
