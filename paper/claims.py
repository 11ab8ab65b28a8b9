"""Every qualitative claim of the paper, checked with numbers under four analyses.

- ``a``: the paper's own method, log10|det Γ| of the square paper-rule Γ in float64; not
  meaningful where its operand is a rank-6 Γ at every point (one station): round-off, whose digits
  depend on the compiled code's rounding.
- ``b``: the same, with structural rank taken into account: a point counts only where Γ has
  rank 7 (:func:`core.observable_rank`: σ_min/σ_max of the column-scaled Γ above
  :data:`core.RANK_RTOL`, spec §4); elsewhere det Γ is structurally 0 and its float64 value is
  round-off.
- ``c_dual``: the physically consistent analysis for 7 unknown states: the D-optimal Fisher
  measure ½ log10 det F (all rows, :data:`core.DEFAULT_STEPS` instants, noise
  :data:`core.DEFAULT_NOISE` V/m). One station gives F singular (−inf); the dual layout is
  d = 15 m unless the claim is about d.
- ``c_known``: the same Fisher measure with the moments known (5 unknown states), for the
  single station unless the claim compares layouts (then both layouts with moments known).

Each check returns a status (``holds``, ``fails``, ``not meaningful``, ``n/a``), the numbers
behind it, one sentence saying why and, where the verdict compares two numbers, its margin: the
relative gap between them. A margin below :data:`WEAK_MARGIN` makes the verdict *weak* (a few per
cent can flip with the grid, the transect's ends or the model). Thresholds are module constants,
stated in the doc.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

import core

from . import scenarios as sc

METHODS = ("a", "b", "c_dual", "c_known")
METHOD_TITLES = {
    "a": "(a) paper's method, float64 log10|det Γ|",
    "b": "(b) same, structural rank enforced (rank Γ = 7)",
    "c_dual": "(c) dual station, Fisher D-optimal (7 states)",
    "c_known": "(c) moments known, Fisher D-optimal (5 states)",
}
#: Horizontal distance from station 1 (m) that counts as "near the station" / "far".
NEAR_M, FAR_M = 50.0, 200.0
#: Annulus width (m) of the radial profiles of Fig. 1.
ANNULUS_M = 50.0
#: Slack (decades) allowed when a profile must be monotone or its drops non-increasing.
MONO_TOL = 0.05
#: A blank (Δ ≤ 0) region "exists" when it covers more than this fraction of the grid.
BLANK_MIN = 0.01
#: Depths (m) for the Fig. 4 depth remark.
FIG4_DEPTHS = (110.0, 120.0, 150.0, 200.0)
#: Fig. 2 points (x, y, z) in m: the near point and the ends of the x and z transects.
FIG2_POINTS = {"near": (0.0, 50.0, 100.0), "x_end": (300.0, 50.0, 100.0), "z_end": (0.0, 50.0, 400.0)}
DUAL_D = sc.DUAL_D
#: A verdict whose margin (relative gap between the two numbers it compares) is below this is
#: reported as weak.
WEAK_MARGIN = 0.05


@dataclass
class Check:
    status: str
    numbers: dict
    note: str
    #: relative gap between the numbers the verdict compares (None: exact or not a comparison)
    margin: float | None = None

    @property
    def weak(self):
        """The verdict rests on a margin below WEAK_MARGIN."""
        return self.margin is not None and self.margin < WEAK_MARGIN


@dataclass
class Claim:
    key: str
    figure: str
    statement: str
    checks: dict = field(default_factory=dict)

    def to_dict(self):
        return {"key": self.key, "figure": self.figure, "statement": self.statement,
                "checks": {m: asdict(c) for m, c in self.checks.items()}}


def _r(x, nd=3):
    """A float for the JSON and the doc, rounded to nd decimals (inf/nan kept)."""
    x = float(x)
    return round(x, nd) if np.isfinite(x) else x


def _status(ok):
    return "holds" if ok else "fails"


def _rel(a, b):
    """Relative gap |a − b| / max(|a|, |b|) between two numbers a verdict compares (0 if both 0)."""
    a, b = float(a), float(b)
    top = max(abs(a), abs(b))
    return round(abs(a - b) / top, 4) if top > 0 else 0.0


def _single_roundoff(plane, model, moments=(sc.PH, sc.PV)):
    """Check (b) for a single-station claim: rank 6 at every point → not meaningful.

    It states the rank verdict, not η's value: a rank-6 Γ's η is round-off whose digits differ
    between kernels compiled in the process and loaded from numba's cache (by ~0.2 decades), and
    the committed report must not depend on which ran."""
    eta = sc.field_map(plane, None, moments, "log10_eta", model)
    if eta.observable.any():
        return None
    return Check("not meaningful", {"full_rank_points": 0, "points": int(eta.observable.size),
                                    "log10_RANK_RTOL": _r(np.log10(core.RANK_RTOL))},
                 "rank 6 at every point (σ_min/σ_max ≤ RANK_RTOL): det Γ = 0 structurally; the "
                 "map is round-off")


#: What (a) says where its operand is a rank-6 Γ everywhere (check (b) not meaningful).
ROUND_OFF_A = ("float64 round-off of a rank-6 Γ: its digits change with the compiled code's rounding "
               "(kernels compiled in the process or loaded from numba's cache move them by up to "
               "two decades, and verdicts drawn from them flip), so none is drawn")


def _paper_method_on_round_off(claim):
    """(a) of a claim whose operand (b) found rank 6 at every point: not meaningful either; the
    round-off maps are still drawn (hatched) to reproduce the paper's figures."""
    b, a = claim.checks.get("b"), claim.checks.get("a")
    if b is not None and a is not None and a.status != "n/a" and "full_rank_points" in b.numbers:
        claim.checks["a"] = Check("not meaningful", dict(b.numbers), ROUND_OFF_A)
    return claim


def _maps(plane, model, d=None, moments=(sc.PH, sc.PV)):
    """The measure maps of the four analyses for one scenario (None where not applicable)."""
    return {
        "a": sc.field_map(plane, d, moments, "log10_det", model).value,
        "c_dual": sc.field_map(plane, sc.DUAL_D if d is None else d, moments, "d_optimal", model).value,
        "c_known": sc.field_map(plane, d, moments, "d_optimal", model, sc.KNOWN).value,
    }


# --------------------------------------------------------------------------------------------
# Fig. 1: largest near the station, growing ever faster as the target approaches


def radial_profile(values, plane):
    """Mean of ``values`` over ANNULUS_M-wide annuli around station 1, innermost first."""
    r = sc.horizontal_range(plane)
    edges = np.arange(0.0, 300.0 + ANNULUS_M, ANNULUS_M)
    return [float(np.nanmean(values[(r >= lo) & (r < hi)])) for lo, hi in zip(edges[:-1], edges[1:])]


def _argmax_range(values, plane):
    iy, ix = np.unravel_index(np.nanargmax(values), values.shape)
    u, v = plane.axes
    return float(np.hypot(u[ix], v[iy]))


def claim_fig1(model, n):
    plane = sc.xy_plane(n)
    near = Claim("C1a", "Fig. 1", "|det Γ| is largest near the station and falls with horizontal range")
    fast = Claim("C1b", "Fig. 1", "|det Γ| grows ever faster as the target approaches the station "
                 "(drop per 50 m annulus largest nearest the station)")
    for m, values in _maps(plane, model).items():
        prof = radial_profile(values, plane)
        drops = -np.diff(prof)
        rmax = _argmax_range(values, plane)
        mono = bool(np.all(drops > -MONO_TOL))
        accel = bool(np.all(np.diff(drops) < MONO_TOL))
        nums = {"annulus_means": [_r(p) for p in prof], "argmax_range_m": _r(rmax, 1)}
        near.checks[m] = Check(_status(rmax <= ANNULUS_M and mono), nums,
                               f"maximum {rmax:.0f} m from the station; annulus means "
                               f"{'fall' if mono else 'do not fall'} monotonically with range")
        fast.checks[m] = Check(_status(mono and accel), {"drops_per_annulus": [_r(x) for x in drops]},
                               "drops per annulus " + ("shrink" if accel else "do not shrink")
                               + " outward: " + ", ".join(f"{x:.2f}" for x in drops))
    b = _single_roundoff(plane, model)
    near.checks["b"] = fast.checks["b"] = b
    return [near, fast]


# --------------------------------------------------------------------------------------------
# Fig. 2: decay along x vs along z, Ph > Pv and Ph = Pv


def fig2_decays(model, moments, method):
    """(Δx, Δz) in decades for the Fig. 2 transects under one analysis."""
    pts = np.array([[*FIG2_POINTS[k], *sc.VELOCITY, *moments] for k in ("near", "x_end", "z_end")])
    if method == "a":
        v = core.log10_abs_det_gamma(pts, sc.stations(), T=sc.T, sigma=sc.SIGMA, model=model)
    else:
        d, known = (sc.DUAL_D, ()) if method == "c_dual" else (None, sc.KNOWN)
        v = core.fisher_measures(pts, sc.stations(d), T=sc.T, known=known,
                                 sensor=core.Sensor("E", sigma=sc.SIGMA, model=model)).d_optimal
    return float(v[0] - v[1]), float(v[0] - v[2])


def claim_fig2(model, n):
    slow = Claim("C2a", "Fig. 2", "with Ph > Pv (100, 20 A·m) |det Γ| decays more slowly along x "
                 "(z = 100 m, x: 0 → 300 m) than along z (x = 0, z: 100 → 400 m), y = 50 m")
    equal = Claim("C2b", "Fig. 2", "with Ph = Pv = 100 A·m it decays about equally along x and z: "
                  "the x/z asymmetry is due to Ph > Pv")
    for m in ("a", "c_dual", "c_known"):
        dx1, dz1 = fig2_decays(model, (sc.PH, sc.PV), m)
        dx2, dz2 = fig2_decays(model, (100.0, 100.0), m)
        a1, a2 = dz1 - dx1, dz2 - dx2
        slow.checks[m] = Check(_status(dx1 < dz1), {"dx": _r(dx1), "dz": _r(dz1), "asymmetry": _r(a1)},
                               f"Δx = {dx1:.2f}, Δz = {dz1:.2f} decades (Δz − Δx = {a1:+.2f}, "
                               f"{100 * a1 / dz1:+.1f} % of Δz)", _rel(dx1, dz1))
        ok = a1 > 0 and abs(a2) <= 0.5 * a1
        equal.checks[m] = Check(_status(ok), {"dx": _r(dx2), "dz": _r(dz2), "asymmetry": _r(a2),
                                              "asymmetry_ph_gt_pv": _r(a1)},
                                f"Δz − Δx = {a2:+.2f} with Ph = Pv vs {a1:+.2f} with Ph > Pv "
                                "(holds if the asymmetry at least halves)",
                                _rel(abs(a2), 0.5 * a1) if a1 > 0 else None)
    b = _single_roundoff(sc.xz_plane(n), model)
    slow.checks["b"] = equal.checks["b"] = b
    return [slow, equal]


# --------------------------------------------------------------------------------------------
# Difference-map helpers (Figs. 3–6)


def blank_fraction(log_a, log_b, where=None):
    """Fraction of points where |A| − |B| ≤ 0 (the paper's blank), via core's log difference."""
    diff = core.log10_positive_difference(log_a, log_b)
    valid = np.isfinite(log_a) | np.isfinite(log_b)
    if where is not None:
        valid &= where
    return float(np.mean(np.isnan(diff[valid]))) if valid.any() else float("nan")


def claim_fig3(model, n):
    plane = sc.xy_plane(n)
    big = (10 * sc.PH, 10 * sc.PV)
    c = Claim("C3", "Fig. 3", "×10 source strength raises |det Γ| everywhere")
    for m, base in _maps(plane, model).items():
        up = _maps(plane, model, moments=big)[m]
        ratio = core.log10_ratio(up, base)
        blank = blank_fraction(up, base)
        c.checks[m] = Check(_status(blank == 0.0), {
            "blank_fraction": _r(blank, 4), "ratio_min": _r(np.nanmin(ratio)),
            "ratio_max": _r(np.nanmax(ratio))},
            f"log10 ratio {np.nanmin(ratio):.3f} … {np.nanmax(ratio):.3f}; blank {100 * blank:.2g} %"
            + (" (5 of 7 columns are linear in the moments: +5 is a scaling identity)"
               if m != "a" else ""))
    c.checks["b"] = _single_roundoff(plane, model)
    return [c]


# --------------------------------------------------------------------------------------------
# Fig. 4: moment redistribution


def fig4_fractions(model, n, method, pair, z=sc.Z):
    """(fraction with Δ > 0 near, far, blank fraction overall) of moments B − A (pair = (B, A))."""
    plane = sc.xy_plane(n, z)
    mb, ma = (sc.FIG4_MOMENTS[i] for i in pair)
    vb, va = _maps(plane, model, moments=mb)[method], _maps(plane, model, moments=ma)[method]
    r = sc.horizontal_range(plane)
    pos = lambda w: 1.0 - blank_fraction(vb, va, w)
    return pos(r <= NEAR_M), pos(r >= FAR_M), blank_fraction(vb, va)


def claim_fig4(model, n):
    lower = Claim("C4a", "Fig. 4", "shifting moment from horizontal to vertical lowers |det Γ| near "
                  f"the station (blank centre, ≤ {NEAR_M:.0f} m) and raises it far away (≥ {FAR_M:.0f} m)")
    only = Claim("C4b", "Fig. 4", "a larger vertical moment raises observability only close to the "
                 "station, a larger horizontal one over a wide range (same paragraph; the opposite of C4a)")
    depth = Claim("C4c", "Fig. 4", "the closer the target's depth to the station's, the larger the "
                  "blank centre of Fig. 4(c), (0, 100) − (100, 0)")
    for m in ("a", "c_dual", "c_known"):
        fr = [fig4_fractions(model, n, m, p) for p in sc.FIG4_PAIRS]
        near = [f[0] for f in fr]
        far = [f[1] for f in fr]
        nums = {"near_positive": [_r(x) for x in near], "far_positive": [_r(x) for x in far]}
        txt = "Δ > 0 on " + ", ".join(f"{100 * a:.0f} % near / {100 * b:.0f} % far" for a, b in zip(near, far))
        margin = min(_rel(f, 0.5) for f in near + far)  # each fraction against one half
        lower.checks[m] = Check(_status(all(a < 0.5 for a in near) and all(b > 0.5 for b in far)), nums, txt,
                                margin)
        only.checks[m] = Check(_status(all(a > 0.5 for a in near) and all(b < 0.5 for b in far)), nums, txt,
                               margin)
        blanks = [fig4_fractions(model, n, m, (2, 0), z)[2] for z in FIG4_DEPTHS]
        shrinking = bool(np.all(np.diff(blanks) <= 0) and blanks[0] > blanks[-1])
        depth.checks[m] = Check(_status(shrinking), {"depths_m": list(FIG4_DEPTHS),
                                                     "blank_fraction": [_r(x, 4) for x in blanks]},
                                "blank fraction at z = " + ", ".join(
                                    f"{z:.0f} m: {100 * b:.1f} %" for z, b in zip(FIG4_DEPTHS, blanks)),
                                min(_rel(a, b) for a, b in zip(blanks[:-1], blanks[1:])))
    b = _single_roundoff(sc.xy_plane(n), model, sc.FIG4_MOMENTS[1])
    lower.checks["b"] = only.checks["b"] = depth.checks["b"] = b
    return [lower, only, depth]


# --------------------------------------------------------------------------------------------
# Figs. 5–6: dual vs single, spacing


def layout_maps(model, n, d):
    """Per analysis, the map of layout d (None: single) over Fig. 5's plane.

    ``b`` is the paper measure with structurally singular points set to −inf (det Γ = 0)."""
    plane = sc.xy_plane(n)
    det = sc.field_map(plane, d, (sc.PH, sc.PV), "log10_det", model)
    return {
        "a": det.value,
        "b": np.where(det.observable | np.isnan(det.value), det.value, -np.inf),
        "c_dual": sc.field_map(plane, d, (sc.PH, sc.PV), "d_optimal", model).value,
        "c_known": sc.field_map(plane, d, (sc.PH, sc.PV), "d_optimal", model, sc.KNOWN).value,
    }


def claim_fig5(model, n):
    blank2 = Claim("C5a", "Fig. 5(a)", "d = 2 m: dual minus single has blank regions (dual not always better)")
    pos15 = Claim("C5b", "Fig. 5(b)", "d = 15 m: dual minus single is positive everywhere")
    single = layout_maps(model, n, None)
    for m in METHODS:
        f2 = blank_fraction(layout_maps(model, n, 2.0)[m], single[m])
        f15 = blank_fraction(layout_maps(model, n, 15.0)[m], single[m])
        nums = {"blank_fraction_d2": _r(f2, 4), "blank_fraction_d15": _r(f15, 4)}
        why = {"a": "", "b": "; the single station is structurally 0, so only unobservable dual "
               "points could be blank", "c_dual": "; single-station F is singular (D-opt = −inf)",
               "c_known": "; both layouts with moments known"}[m]
        blank2.checks[m] = Check(_status(f2 > BLANK_MIN), nums, f"blank {100 * f2:.1f} % of the map{why}",
                                 _rel(f2, BLANK_MIN))
        pos15.checks[m] = Check(_status(f15 == 0.0), nums, f"blank {100 * f15:.1f} % of the map{why}")
    return [blank2, pos15]


def claim_fig6(model, n):
    c = Claim("C6", "Fig. 6", "growing d (20, 50, 100 m vs 10 m) enlarges the blank region near the stations")
    base = layout_maps(model, n, sc.FIG6_BASE)
    r = sc.horizontal_range(sc.xy_plane(n))
    for m in METHODS:
        tot = [blank_fraction(layout_maps(model, n, d)[m], base[m]) for d in sc.FIG6_D]
        near = [blank_fraction(layout_maps(model, n, d)[m], base[m], r <= 100.0) for d in sc.FIG6_D]
        grows = bool(np.all(np.diff(tot) > 0))
        c.checks[m] = Check(_status(grows), {"d_m": list(sc.FIG6_D), "blank_fraction": [_r(x, 4) for x in tot],
                                             "blank_fraction_within_100m": [_r(x, 4) for x in near]},
                            "blank " + ", ".join(f"d = {d:.0f}: {100 * t:.1f} % (≤ 100 m: {100 * q:.0f} %)"
                                                 for d, t, q in zip(sc.FIG6_D, tot, near)),
                            min(_rel(a, b) for a, b in zip(tot[:-1], tot[1:])))
    return [c]


# --------------------------------------------------------------------------------------------
# Conclusions 1–3


def grid_states(plane, moments=(sc.PH, sc.PV)):
    return plane.states(sc.VELOCITY, moments).reshape(-1, 7)


def claim_conclusions(model, n, scan):
    plane = sc.xy_plane(n)
    pts = grid_states(plane)
    k1 = Claim("K1", "Conclusion 1", "the single-station system is observable (Mathematica: rank Γ = 7)")
    det = sc.field_map(plane, None, (sc.PH, sc.PV), "log10_det", model).value
    finite = float(np.mean(np.isfinite(det)))
    k1.checks["a"] = Check(_status(finite == 1.0), {"fraction_det_nonzero": _r(finite, 4)},
                           f"float64 det Γ ≠ 0 at {100 * finite:.1f} % of the Fig. 1 grid, so the paper's "
                           "test |det Γ| ≠ 0 says observable")
    kw = dict(T=sc.T, sensor=core.Sensor("E", sigma=sc.SIGMA, model=model))
    rank = core.observable_rank(pts, sc.stations(), **kw)
    k1.checks["b"] = Check(_status(np.all(rank == 7)), {"rank_counts": {str(k): int(v) for k, v in zip(*np.unique(rank, return_counts=True))}},
                           f"structural rank {', '.join(f'{k}: {v} points' for k, v in zip(*np.unique(rank, return_counts=True)))}")
    rd = core.observable_rank(pts, sc.stations(DUAL_D), **kw)
    k1.checks["c_dual"] = Check("n/a", {"dual_rank7_fraction": _r(np.mean(rd == 7), 4)},
                                f"a different system; dual (d = {DUAL_D:.0f} m) rank 7 at {100 * np.mean(rd == 7):.1f} %")
    rk = core.observable_rank(pts, sc.stations(), known=sc.KNOWN, **kw)
    k1.checks["c_known"] = Check(_status(np.all(rk == 5)), {"rank5_fraction": _r(np.mean(rk == 5), 4)},
                                 f"one station with the moments known: rank 5 of 5 at {100 * np.mean(rk == 5):.1f} %")

    k2 = Claim("K2", "Conclusion 2", "with Pv < Ph depth z is less observable than horizontal position "
               "(harder to estimate), and this follows the Ph : Pv split")
    k2.checks["a"] = Check("n/a", {}, "the paper's evidence is Fig. 2: see C2a, C2b")
    k2.checks["b"] = Check("not meaningful", {}, "single-station Γ is rank 6 (see C2a)")
    for m, (d, known) in {"c_dual": (DUAL_D, ()), "c_known": (None, sc.KNOWN)}.items():
        med = []
        for mom in ((sc.PH, sc.PV), (100.0, 100.0)):
            std = core.fisher_measures(grid_states(plane, mom), sc.stations(d), known=known, **kw).std
            ratio = std[:, 2] / np.sqrt(0.5 * (std[:, 0] ** 2 + std[:, 1] ** 2))
            med.append(float(np.median(ratio)))
        ok = med[0] > 1.0 and med[0] > med[1]
        k2.checks[m] = Check(_status(ok), {"median_sz_over_sxy_100_20": _r(med[0]),
                                           "median_sz_over_sxy_100_100": _r(med[1])},
                             f"median CRLB σz / σxy over the Fig. 1 grid: {med[0]:.2f} with (100, 20), "
                             f"{med[1]:.2f} with (100, 100)", min(_rel(med[0], 1.0), _rel(med[0], med[1])))

    k3 = Claim("K3", "Conclusion 3", "dual beats single, but the spacing must suit the target: too large "
               "a d lowers observability near the stations")
    k3.checks["a"] = Check("n/a", {}, "see C5a, C5b, C6")
    k3.checks["b"] = Check("n/a", {}, "see C5a, C5b, C6")
    for m, key in (("c_dual", "d_optimal"), ("c_known", "d_optimal_known")):
        peaks = scan[model]["peaks"]  # refined optima (paper.beyond.refine_peak), not grid points
        d = np.asarray(scan["d_m"])
        best, best_near = peaks[key]["d"], peaks[f"{key}_near"]["d"]
        ok = best_near < d[-1]
        k3.checks[m] = Check(_status(ok), {"argmax_mean_d_m": _r(best, 2), "argmax_near_d_m": _r(best_near, 2)},
                             f"mean D-opt over the map peaks at d = {best:.1f} m; within {NEAR_M:.0f} m "
                             f"of station 1 at d = {best_near:.1f} m (scan to {d[-1]:.0f} m); any dual "
                             "layout beats one station (F singular)" if m == "c_dual" else
                             f"mean D-opt over the map peaks at d = {best:.1f} m; within {NEAR_M:.0f} m "
                             f"of station 1 at d = {best_near:.1f} m (scan to {d[-1]:.0f} m)")
    return [k1, k2, k3]


def evaluate_claims(model, n, scan):
    """All claims for one field model on n × n grids; ``scan`` from :func:`paper.beyond.d_scan`."""
    out = []
    for fn in (claim_fig1, claim_fig2, claim_fig3, claim_fig4, claim_fig5, claim_fig6):
        out.extend(fn(model, n))
    out.extend(claim_conclusions(model, n, scan))
    return [_paper_method_on_round_off(c) for c in out]
