"""Every sensor kind's results did not move with one engine for every kind (issue 36).

tests/data/sensor_baseline.npz holds the results of every measure for E (whole space and a
layered sea), B, G, BG and gradiometers with a baseline (one and two), at seeded random points
and on small map grids, made by tests/create_data/make_sensor_baseline.py from the core before
the change (ecd374c). The core must reproduce them: the electric results to 1e-12 relative, the
magnetic ones to 1e-10, with the same non-finite entries and the same verdicts (ranks, the
observable flags, the station mask) exactly.

What the tolerances are relative to:
- a measurement h: the largest component of the same station's vector; a Jacobian or a Γ: the
  largest entry of the same column (entries that cancel to ~0 carry their column's round-off);
- a Fisher matrix F (and a CRLB covariance C): entry (i, j) relative to sqrt(F_ii F_jj) (to
  sqrt(C_ii C_jj)), the bound of a sum of products of the columns i and j.

Ill-conditioned points are held to their condition number's error bound. Kernels compiled in the
running process and the same kernels loaded from numba's cache round differently in the last
bits, and an ill-conditioned solve amplifies that, so without these bounds the verdict would
depend on the cache (it does not: the test passes with an empty ``NUMBA_CACHE_DIR`` and a warm
one):
- a CRLB (the covariance, its standard deviations, the ellipse's axes, σz, σ_speed, the position
  error) is the inverse of F computed from the column-scaled Γ: its relative round-off is up to
  ~cond(F_s) · ε, F_s being F scaled to a unit diagonal; allowed: max(rtol, 16 ε cond(F_s));
- ½ log10 det F and log10 η sum the logs of F_s's eigenvalues, each moved by ≲ ε cond(F_s):
  allowed max(rtol relative, 16 ε cond(F_s) / ln 10) in log10 units; log10|det Γ| of the square
  Γ and log10 η of the paper's square Γ likewise with the cond of the column-scaled Γ
  (σ_max/σ_min). 16 ≥ the 7 or 8 eigenvalues, with room for the rounding of the products that
  form F;
- log10 η of the all-rows Γ (``eta3``, m × n, m = 15 … 48 rows, n = 7 or 8): the kernel folds the
  rows of Γ into R by Givens rotations (core/kernels/measures.py; no LAPACK) and sums log10 R_jj −
  log10 ‖Γ_j‖. To first order a column perturbation E of Γ_s moves ln η = Σ ln σ_i by
  tr(Γ_s⁺ E), so |Δ ln η| ≤ Σ_j ‖e_jᵀ Γ_s⁺‖ δ_j, δ_j the relative move of column j. δ_j has two
  sources in each run: the rotations' backward error, ≤ γ̃_{m+n−1} per column (the fold is
  m + n − 1 stages of disjoint rotations; Higham, Accuracy and Stability, 2nd ed., §19.6: a
  Givens QR in m + n − 2 stages has γ̃_{m+n−2}, γ̃_k = c k u / (1 − c k u), c a small constant),
  taken as (m + n − 1) ε per run (c = 2, u = ε/2), and the rounding of Γ's entries,
  which no dimension bounds: a gradiometer with a baseline reads the difference of two
  magnetometers L = 0.5 m apart at 5–100 m, and each machine's rounding (FMA contraction and
  vectorisation follow the CPU) is amplified by that cancellation: today's Γ (``gamma3``) and the
  reference's differ by up to ~200 ε per column there, by ≤ 7 ε for every other kind. So allowed:
  Σ_j ‖e_jᵀ Γ_s⁺‖ (‖ΔΓ_j‖ / ‖Γ_j‖ + 2 (m + n − 1) ε) / ln 10 (two runs), ΔΓ = today's Γ −
  the reference's, held itself to rtol; Σ_j ‖e_jᵀ Γ_s⁺‖ lies between 0.95 and 2.7 cond(Γ_s) on
  these points. (The former 16 ε cond(Γ_s), per eigenvalue ε, missed both factors: on an AMD
  EPYC, ln η of 3 Gb points at cond 1.1e6–4.3e6 moved by 16–18 ε cond, while ln η of the
  reference's Γ and of today's, both by numpy's SVD, differ by up to 19 ε cond: the move is Γ's,
  not the fold's);
- an ellipse's orientation (degrees): the eigenvector of the 2 × 2 block moves by ≲ δ a² / (a² −
  b²) radians for a relative perturbation δ of the block (a, b its semi-axes), with a floor of
  rtol of its range (90°); compared modulo 180°;
- a layout criterion over a region (mean or worst D-optimal) by the largest of its points' bounds.

Where the reference's verdict says "singular" (rank below the state size, or not observable), a
measure's finite value is float64 round-off of a singular matrix (its digits are the rounding's,
and they differ between cold and warm caches): there only what the code sets from the verdict
(±inf, NaN) is compared; the verdicts themselves are compared exactly in their own arrays.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import core
from tests.create_data.make_sensor_baseline import E_TARGET, M_TARGET, REGIONS, SENSORS, cases

DATA = np.load(Path(__file__).parent / "data" / "sensor_baseline.npz")
EPS = np.finfo(float).eps
CASES = dict(cases())
NAME = re.compile(r"^(?P<what>.+)_(?P<sensor>" + "|".join(SENSORS) + r")_(?P<where>[a-z]+)$")
#: Per-point results that are CRLBs (inverse Fisher).
INVERSES = ("crlbcov", "fm_std", "fm_position_std", "ell_semi_major", "ell_semi_minor",
            "ell_sigma_z", "ell_sigma_speed", "ell_position", "map_crlb_position",
            "crlbmap_semi_major", "crlbmap_semi_minor", "crlbmap_sigma_z", "crlbmap_sigma_speed",
            "crlbmap_position")


def rtol(sensor):
    """The issue's tolerance: 1e-12 relative for the electric kind, 1e-10 for magnetic ones."""
    return 1e-12 if SENSORS[sensor][2] else 1e-10


def scaled_cond(fisher):
    """cond of F scaled to a unit diagonal (D^-½ F D^-½), per matrix; NaN where F is NaN."""
    f = np.asarray(fisher)
    flat = f.reshape((-1,) + f.shape[-2:])
    out = np.full(flat.shape[0], np.nan)
    ok = np.all(np.isfinite(flat), axis=(1, 2))
    d = np.sqrt(np.einsum("...ii->...i", flat[ok]))
    with np.errstate(divide="ignore", invalid="ignore"):
        out[ok] = np.linalg.cond(flat[ok] / (d[:, :, None] * d[:, None, :]))
    return out.reshape(f.shape[:-2])


def gamma_cond(gamma):
    """σ_max/σ_min of the column-scaled Γ (the core's rank criterion's ratio, inverted)."""
    g = np.asarray(gamma)
    flat = g.reshape((-1,) + g.shape[-2:])
    out = np.full(flat.shape[0], np.nan)
    ok = np.all(np.isfinite(flat), axis=(1, 2))
    s = np.linalg.svd(flat[ok] / np.linalg.norm(flat[ok], axis=-2, keepdims=True),
                      compute_uv=False)
    with np.errstate(divide="ignore"):
        out[ok] = s[:, 0] / s[:, -1]
    return out.reshape(g.shape[:-2])


def verdict(what, sensor, where):
    """The reference's own verdict (True: full rank / observable) that decides where ``what``
    is round-off, per point; None where no verdict applies."""
    key = f"{sensor}_{where}"
    n = SENSORS[sensor][0].n_states
    if what == "eta3":
        return DATA[f"rank3_{key}"] == n
    if what in ("logdet", "etasq"):
        return DATA[f"ranksq_{key}"] == 7
    if what.startswith(("fm_", "crlbcov")) or (what.startswith("ell_") and what != "ell_observable"):
        return DATA[f"fm_observable_{key}"]
    if what.startswith("map_"):
        return DATA[f"mapobs_{what[4:]}_{key}"]
    if what.startswith("crlbmap_") and what != "crlbmap_observable":
        return DATA[f"crlbmap_observable_{key}"]
    return None


def cond_of(what, sensor, where):
    """Per-point condition number behind ``what``'s round-off bound, or None."""
    key = f"{sensor}_{where}"
    if what in ("logdet", "etasq"):
        return gamma_cond(DATA[f"gammasq_{key}"])
    if what in ("map_log10_det", "map_log10_eta"):
        return gamma_cond(DATA[f"mapgammasq_{key}"])
    if what.startswith(("map_", "crlbmap_")):
        return scaled_cond(DATA[f"mapfisher_{key}"])
    if what.startswith(("fm_", "crlbcov", "ell_")):
        return scaled_cond(DATA[f"fisher_{key}"])
    return None


def eta_bound(key):
    """Allowed |Δ ln η| of the all-rows η per point (module notes): Σ_j ‖e_jᵀ Γ_s⁺‖ (‖ΔΓ_j‖ /
    ‖Γ_j‖ + 2 (m + n − 1) ε), Γ_s the reference's column-scaled Γ; NaN where Γ is NaN."""
    ref = DATA[f"gamma3_{key}"]
    moved = np.asarray(CASES[f"gamma3_{key}"]()) - ref
    out = np.full(ref.shape[:-2], np.nan)
    ok = np.all(np.isfinite(ref), axis=(-2, -1))
    m, n = ref.shape[-2:]
    norms = np.linalg.norm(ref[ok], axis=-2)  # (P, n)
    rows = np.linalg.norm(np.linalg.pinv(ref[ok] / norms[:, None, :]), axis=-1)  # ‖e_jᵀ Γ_s⁺‖
    delta = np.linalg.norm(moved[ok], axis=-2) / norms + 2 * (m + n - 1) * EPS
    out[ok] = np.sum(rows * delta, axis=-1)
    return out


def per_point(values, ref_shape):
    """Broadcast a per-point array over the trailing axes of a result."""
    v = np.asarray(values)
    return np.broadcast_to(v.reshape(v.shape + (1,) * (len(ref_shape) - v.ndim)), ref_shape)


def scale_of(what, ref):
    """What an element's relative tolerance is relative to (module notes)."""
    a = np.abs(np.where(np.isfinite(ref), ref, 0.0))
    if what == "h":
        return np.broadcast_to(a.max(axis=-1, keepdims=True), ref.shape)
    if what in ("H", "gamma3", "gammasq", "mapgammasq"):
        flat = a.reshape(a.shape[:-3] + (-1,) + a.shape[-1:]) if what == "H" else a
        return np.broadcast_to(flat.max(axis=-2, keepdims=True), flat.shape).reshape(ref.shape)
    if what in ("fisher", "mapfisher", "crlbcov"):
        d = np.sqrt(np.abs(np.einsum("...ii->...i", np.where(np.isfinite(ref), ref, 0.0))))
        return d[..., :, None] * d[..., None, :]
    return a


def test_every_case_is_in_the_data():
    assert set(CASES) == set(DATA.files)
    assert all(NAME.match(name) for name in CASES)


def test_every_kind_and_measure_is_covered():
    """The baseline covers each sensor at random points and on both planes, with every map
    measure of its kind, and holds ill-conditioned but observable points (the bounds above are
    exercised, not vacuous)."""
    for sensor, (s, _, electric) in SENSORS.items():
        for where in ("xy", "xz"):
            for m in (core.MEASURES if electric else ("d_optimal", "crlb_position")):
                assert f"map_{m}_{sensor}_{where}" in DATA.files
        # the station mask is in every xy map (the plane passes through a station)
        assert np.isnan(DATA[f"map_d_optimal_{sensor}_xy"]).any()
    conds = np.concatenate([scaled_cond(DATA[f])[DATA["fm_observable_" + f[len("fisher_"):]]]
                            for f in DATA.files if f.startswith("fisher_")])
    assert np.nanmax(conds) > 1e6


@pytest.mark.parametrize("name", sorted(CASES))
@np.errstate(invalid="ignore", over="ignore")  # inf · 0 where a bound or a scale is infinite
def test_result_unchanged(name):
    what, sensor, where = NAME.match(name).group("what", "sensor", "where")
    ref = DATA[name]
    now = np.asarray(CASES[name]())
    assert now.shape == ref.shape and now.dtype.kind == ref.dtype.kind
    if ref.dtype.kind in "biu":  # ranks, verdicts, the mask: exactly
        np.testing.assert_array_equal(now, ref)
        return
    rel = rtol(sensor)
    keep = np.ones(ref.shape, dtype=bool)
    ok = verdict(what, sensor, where)
    if ok is not None:  # round-off where singular: only what the verdict sets
        noise = ~per_point(ok, ref.shape)
        set_by_verdict = noise & ~np.isfinite(ref)
        np.testing.assert_array_equal(now[set_by_verdict], ref[set_by_verdict])
        keep = ~noise
    np.testing.assert_array_equal(np.isfinite(now[keep]), np.isfinite(ref[keep]))
    np.testing.assert_array_equal(now[keep & ~np.isfinite(ref)], ref[keep & ~np.isfinite(ref)])
    fin = keep & np.isfinite(ref)
    scale = scale_of(what, ref)
    cond = cond_of(what, sensor, where)
    if what.startswith("criterion_"):
        tol = np.array([rel * abs(ref[0]), 0.0])  # the observable fraction: exactly
        if what != "criterion_area_crlb":
            tol[0] = max(tol[0], 16 * EPS * np.nanmax(region_conds(sensor)) / np.log(10))
        with np.errstate(invalid="ignore"):
            assert np.all(np.abs(now - ref) <= tol), (now, ref, tol)
        return
    allowed = rel * scale
    if what == "eta3":
        allowed = np.maximum(rel * scale, eta_bound(f"{sensor}_{where}") / np.log(10))
    elif cond is not None:
        cond = per_point(cond, ref.shape)
        if what in INVERSES:
            allowed = np.maximum(rel, 16 * EPS * cond) * scale
        elif what.endswith("orientation"):
            prefix = what[: -len("orientation")]
            a = DATA[f"{prefix}semi_major_{sensor}_{where}"]
            b = DATA[f"{prefix}semi_minor_{sensor}_{where}"]
            with np.errstate(divide="ignore", invalid="ignore"):
                gap = a**2 / (a**2 - b**2)
            allowed = np.maximum(rel * 90.0, np.degrees(np.maximum(rel, 16 * EPS * cond) * gap))
            with np.errstate(invalid="ignore"):  # ±inf / NaN outside ``fin``
                diff = (now - ref + 90.0) % 180.0 - 90.0
            assert np.all(np.abs(diff[fin]) <= allowed[fin])
            return
        else:  # log10 measures
            allowed = np.maximum(rel * scale, 16 * EPS * cond / np.log(10))
    with np.errstate(invalid="ignore"):  # ±inf / NaN outside ``fin``
        bad = fin & ~(np.abs(now - ref) <= allowed)
    assert not bad.any(), (
        f"{bad.sum()} of {fin.sum()} elements off; worst relative to the allowed: "
        f"{np.max(np.abs(now - ref)[bad] / allowed[bad]):.3g}")


def region_conds(sensor):
    """cond of F_s at the region's points of a layout criterion (observable ones)."""
    s, stations, electric = SENSORS[sensor]
    target = E_TARGET if electric else M_TARGET
    states = REGIONS[electric].states(target["velocity"], target["moments"]).reshape(-1, s.n_states)
    m = core.fisher_measures(states, stations["dual"], sensor=s)
    f = core.fisher_information(states[m.observable], stations["dual"], sensor=s)
    return scaled_cond(f)
