"""One case of seed 003: simulate the pass, run Euler, the UKF and the NHUKF, fit the whole pass
in one batch (:mod:`.fit`, started from the filters' end states), read the shape.

Monte Carlo: the truth (target, pass) is fixed; each run draws its own noise (and the same
outliers), so its Euler start, and hence the filters' start, differ. Run r uses
``numpy.random.default_rng([seed, r])``: results do not depend on how runs are batched.

Metrics (per filter; "position" is the centroid of the N dipoles, or Euler's point; what each
field of the summary means: docs/shape.md, *Command line*): errors of the centroid at the last
sample and at their peak after :data:`SETTLE` samples (:func:`settle_samples` on a shorter pass),
the PCA of the final dipoles against the target's main scale and axis, and the centroid's NEES (c − c_true)ᵀ (A P Aᵀ)⁻¹ (c − c_true),
3 degrees of freedom (A averages the dipole positions: the true target is not a 4-dipole state,
so only the centroid has a truth to compare with). The batch fit (``"fit"``) has one estimate
per pass, not a track.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..model.magnetic import EULER_RCOND, euler_locate
from ..tracking import unscented as uk
from . import model as md
from . import bound as bd
from .bound import read_gradients
from .fit import fit_pass
from .pca import axis_angle_deg, pca_shape
from .targets import Outliers, Pass, Target

__all__ = ["BASELINE", "NOISE_B", "NOISE_G", "SETTLE", "Case", "CaseResult", "euler_point",
           "run_case", "simulate", "verdict"]

#: Gradiometer baseline of the truth (m), seed 003's Ls.
BASELINE = bd.BASELINE
#: Noise σ of each tensor component (nT/m) and of each field component (nT): seed 003's
#: "0.01 nT" measurement precision, read as nT/m for the tensor.
NOISE_G = 0.01
NOISE_B = 0.01
#: Condition number of G above which an Euler fix is flagged (near the plane m ⊥ r).
EULER_FLAG_COND = 100.0
#: Samples after which peak errors and NEES are counted.
SETTLE = 10


@dataclass(frozen=True)
class Case:
    """A scenario: target, pass, noise, outliers and filter settings."""

    name: str
    target: Target = field(default_factory=Target)
    track: Pass = field(default_factory=Pass)
    outliers: Outliers = field(default_factory=Outliers)
    noise_g: float = NOISE_G
    noise_b: float = NOISE_B
    baseline: float = BASELINE
    huber_u: float = uk.HUBER_U
    lag: int = 0
    description: str = ""
    #: A row run beside the case's own for comparison (the one-sample update: cases.py).
    comparison: bool = False

    def to_dict(self):
        return {"name": self.name, "description": self.description, "target": self.target.to_dict(),
                "pass": self.track.to_dict(), "outliers": self.outliers.to_dict(),
                "noise_g_nT_per_m": self.noise_g, "noise_b_nT": self.noise_b,
                "baseline_m": self.baseline, "huber_u": self.huber_u, "lag": self.lag,
                "update": ("one-sample" if self.lag == 0 else f"window, lag {self.lag}"),
                "comparison": self.comparison,
                "n_dipoles": md.N_DIPOLES}


def simulate(case):
    """Noise-free readings of the truth: B (K, 3) nT and the 5 tensor components (K, 5) nT/m of
    the target's cells seen by the finite-baseline gradiometer along the pass."""
    t = case.target
    st = case.track.positions
    B = md.dipole_field(t.positions, t.moments, st).sum(axis=0)  # (K, 3): the magnetometers' mean
    return B, md.cells_tensor5(t.positions, t.moments, st, case.baseline)


def full_tensor(g5):
    """The symmetric traceless 3 × 3 tensor (..., 3, 3) of the 5 components (..., 5)."""
    g5 = np.asarray(g5, float)
    G = np.empty(g5.shape[:-1] + (3, 3))
    for c, (i, j) in enumerate(md.G_COMPONENTS):
        G[..., i, j] = G[..., j, i] = g5[..., c]
    G[..., 2, 2] = -g5[..., 0] - g5[..., 3]
    return G


def euler_point(B, g5):
    """Euler's point fix from each reading, r = −3 G⁻¹ B (:func:`core.euler_locate`;
    r = sensor − source), with G's condition number.

    Parameters
    ----------
    B : ndarray, shape (..., 3)
        Field (nT).
    g5 : ndarray, shape (..., 5)
        Tensor components (nT/m); the tensor is rebuilt symmetric and traceless.

    Returns
    -------
    r : ndarray, shape (..., 3)
        NaN where G is singular (the plane m ⊥ r: core's EULER_RCOND).
    cond : ndarray, shape (...)
        σmax / σmin of G: large near that plane, where a small error moves the fix far (seed
        003's remark on the third-order method; flagged above :data:`EULER_FLAG_COND`).
    """
    G = full_tensor(g5)
    sv = np.linalg.svd(G, compute_uv=False)
    with np.errstate(divide="ignore"):  # σmin = 0 exactly: cond = inf, r = NaN
        cond = sv[..., 0] / sv[..., -1]
    ok = sv[..., -1] >= EULER_RCOND * sv[..., 0]
    r = np.full(np.shape(B), np.nan)
    r[ok] = euler_locate(np.asarray(B)[ok], G[ok])
    return r, cond


@dataclass
class CaseResult:
    case: Case
    runs: int
    times: np.ndarray  # (K,)
    platform_x: np.ndarray  # (K,)
    outlier_samples: list
    errors: dict  # filter -> (R, K) position error (m)
    final: dict  # filter -> dict of arrays over runs
    dipoles: dict  # filter -> (R, N, 3) final dipole positions
    euler_cond: np.ndarray  # (R, K)
    nees: dict  # filter -> (R, K) centroid NEES
    #: The batch fit's model bias (:func:`model_bias`); empty without the fit.
    model_bias: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)


def _noisy(case, B, g5, runs, seed):
    K = g5.shape[0]
    zb = np.empty((runs, K, 3))
    zg = np.empty((runs, K, 5))
    for r in range(runs):
        rng = np.random.default_rng([int(seed), r])
        zg[r] = g5 + case.noise_g * rng.standard_normal((K, 5))
        zb[r] = B + case.noise_b * rng.standard_normal((K, 3))
    hit = case.outliers.apply(zg, g5, case.noise_g, case.track)
    return zb, zg, hit


def _point_moment(r_src, B, station):
    """Total moment that makes a point dipole at r_src give B at one station (least squares on
    the core's field, which is linear in the moment)."""
    cols = [md.dipole_field(r_src, np.broadcast_to(e, r_src.shape), station[None])[:, 0, :]
            for e in np.eye(3)]
    M = np.stack(cols, axis=-1)  # (R, 3, 3)
    return np.linalg.solve(M, B[..., None])[..., 0]


def _final(s, x_moment, case):
    return {"main_scale_m": s.main_scale, "kind": s.kind, "spread_scale_m": s.spread_scale,
            "axis_error_deg": axis_angle_deg(s.axis, case.target.axis),
            "eigenvalues": s.eigenvalues, "axes": s.axes, "centroid": s.centroid,
            "moment": x_moment}


def scale_sigma(x, cov, n=md.N_DIPOLES):
    """σ (m) of the span read and the second-moment read of the main scale of state ``x``
    (3n + 3,) with covariance ``cov`` (delta method, :func:`core.shape.bound.read_gradients`;
    a plane's two reads are both its diameter's); NaN if ``x`` is not finite."""
    if not np.all(np.isfinite(x)) or not np.all(np.isfinite(cov)):
        return float("nan"), float("nan")
    _, dL, _, dS = read_gradients(x, n)
    span = float(np.sqrt(max(dL @ cov @ dL, 0.0)))
    line = str(pca_shape(x[: 3 * n].reshape(n, 3)).kind) == "line"
    return span, float(np.sqrt(max(dS @ cov @ dS, 0.0))) if line else span


def model_bias(case, g5=None):
    """:func:`core.shape.bound.model_bias` of ``case`` (its target, pass, noise, array and
    Huber's u), from its noise-free readings ``g5`` (K, 5) if given."""
    return bd.model_bias(case.target, case.track, case.noise_g, baseline=case.baseline,
                         u=case.huber_u, g5=g5)


def run_case(case, runs=1, seed=0, filters=("ukf", "nhukf"), fit=True):
    """Run ``runs`` Monte-Carlo passes of ``case``; returns a :class:`CaseResult`. ``fit``: also
    the batch fit of each pass (:func:`core.shape.fit.fit_pass`, one-sample readings, the
    array's baseline, Huber's u of the case), started from every filter's end state."""
    trk = case.track
    st = trk.positions
    K = st.shape[0]
    B, g5 = simulate(case)
    zb, zg, hit = _noisy(case, B, g5, runs, seed)
    r_eu, cond = euler_point(zb, zg)
    src_eu = st - r_eu  # (R, K, 3)
    truth_c = case.target.centroid
    errors = {"euler": np.linalg.norm(src_eu - truth_c, axis=-1)}
    # start: Euler at the first sample, moment from its field
    m0 = _point_moment(src_eu[:, 0], zb[:, 0], st[0])
    x0, P0 = md.start_state(src_eu[:, 0], m0)
    n = md.N_DIPOLES
    Q = np.diag(np.r_[np.full(3 * n, md.Q_POSITION), np.full(3, md.Q_MOMENT)])
    final, dipoles, nees = {}, {}, {}
    A = np.zeros((3, 3 * n + 3))
    for j in range(n):
        A[:, 3 * j: 3 * j + 3] = np.eye(3) / n

    def score(name, xs, Ps):
        """Centroid errors and NEES (R, K), final dipoles and shape of states xs (R, K, 3N + 3)
        with covariances Ps (R, K, 3N + 3, 3N + 3)."""
        pos = xs[..., : 3 * n].reshape(xs.shape[:2] + (n, 3))
        e = pos.mean(axis=2) - truth_c
        errors[name] = np.linalg.norm(e, axis=-1)
        Pc = A @ Ps @ A.T  # (R, K, 3, 3)
        nees[name] = np.einsum("rki,rki->rk", e, np.linalg.solve(Pc, e[..., None])[..., 0])
        dipoles[name] = pos[:, -1]
        final[name] = _final(pca_shape(pos[:, -1]), xs[:, -1, 3 * n:], case)

    # all filters in one stack (one tensor call a step): rows f·R … f·R + R − 1 are filter f
    mdl = md.DipoleModel(st, lag=case.lag)
    zs = mdl.window_measurements(zg)
    R = case.noise_g**2 * np.eye(mdl.n_meas)
    nf = len(filters)
    u = np.repeat([case.huber_u if name == "nhukf" else np.inf for name in filters], runs)
    with np.errstate(all="ignore"):
        res = uk.run_ukf(np.tile(x0, (nf, 1)), np.tile(P0, (nf, 1, 1)), np.tile(zs, (nf, 1, 1)),
                         mdl.hx, R, Q=Q, u=u)
    for f, name in enumerate(filters):
        score(name, res.x[f * runs:(f + 1) * runs], res.P[f * runs:(f + 1) * runs])
    if fit:
        ends = res.x[:, -1].reshape(nf, runs, -1)
        fits = [fit_pass(zg[r], st, ends[:, r], case.noise_g, baseline=case.baseline, u=case.huber_u)
                for r in range(runs)]
        X = np.stack([f.x for f in fits])
        cov = np.stack([f.cov for f in fits])
        score("fit", X[:, None], cov[:, None])  # one estimate per pass: K = 1
        final["fit"].update(misfit=np.array([f.misfit for f in fits]),
                            converged=np.array([f.converged for f in fits]),
                            plausible=np.array([f.plausible for f in fits]),
                            scale_sigma_m=np.array([scale_sigma(f.x, f.cov) for f in fits]),
                            covariance=cov, state=X)
    out = CaseResult(case=case, runs=runs, times=trk.times, platform_x=st[:, 0],
                     outlier_samples=hit, errors=errors, final=final, dipoles=dipoles,
                     euler_cond=cond, nees=nees, model_bias=model_bias(case, g5) if fit else {})
    out.summary = summarise(out)
    return out


def verdict(kinds, scales):
    """The verdict over runs: (kind, share per kind, median main scale per kind).

    ``kind`` is the majority verdict, ``"tie"`` when line and plane have as many runs. A line's
    main scale is a length and a plane's a diameter, so the medians are per kind: the summary's
    ``main_scale_m`` is the majority kind's (NaN on a tie, where ``main_scale_by_kind_m`` gives
    both)."""
    kinds = np.asarray(kinds)
    scales = np.asarray(scales, float)
    names, counts = np.unique(kinds, return_counts=True)
    top = names[counts == counts.max()]
    kind = str(top[0]) if top.size == 1 else "tie"
    share = {str(k): float(c / kinds.size) for k, c in zip(names, counts)}
    by_kind = {str(k): float(np.median(scales[kinds == k])) for k in names}
    return kind, share, by_kind


def settle_samples(samples):
    """Samples skipped before a track's peak error and NEES are counted: :data:`SETTLE`, or on a
    pass of ≤ SETTLE samples all but the last (issue 46: a 9-sample pass had no sample left, and
    its summary crashed)."""
    return min(SETTLE, int(samples) - 1)


def _scores(f, nees, truth_scale):
    """An estimator's medians over the runs given (``f``'s arrays and ``nees`` already chosen);
    with no run, NaN and kind "none"."""
    if len(f["kind"]) == 0:
        return {"main_scale_m": float("nan"), "main_scale_by_kind_m": {}, "kind": "none",
                "main_scale_error_m": float("nan"), "axis_error_deg": float("nan"),
                "kind_share": {}, "spread_scale_m": float("nan"), "nees": float("nan"),
                "nees_dof": 3, "moment_total_Am2": [float("nan")] * 3}
    kind, share, by_kind = verdict(f["kind"], f["main_scale_m"])
    return {
        "main_scale_m": by_kind.get(kind, float("nan")),
        "main_scale_by_kind_m": by_kind,
        "main_scale_error_m": float(np.median(np.abs(f["main_scale_m"] - truth_scale))),
        "axis_error_deg": float(np.median(f["axis_error_deg"])),
        "kind": kind,
        "kind_share": share,
        "spread_scale_m": float(np.median(f.get("spread_scale_m", np.nan))),
        "nees": float(np.nanmean(nees)),
        "nees_dof": 3,
        "moment_total_Am2": (np.median(f["moment"], axis=0) * md.N_DIPOLES).tolist(),
    }


def _fit_summary(res, d):
    """The batch fit's entry (module notes): medians over its converged passes only (a fit that
    did not converge, or ended implausibly far, is no answer: ``converged_share`` counts them),
    its σ of the main scale and the model bias beside it."""
    f = res.final["fit"]
    keep = np.asarray(f["converged"], bool)
    n = int(keep.sum())
    sub = {k: (v[keep] if isinstance(v, np.ndarray) and v.shape[:1] == keep.shape else v)
           for k, v in f.items()}
    with np.errstate(invalid="ignore"):
        d["centroid_error_m"] = float(np.median(res.errors["fit"][keep, -1])) if n else float("nan")
    d.update(_scores(sub, res.nees["fit"][keep], res.case.target.main_scale))
    d["nees_band"] = ([float(v) for v in stats.chi2.ppf([0.005, 0.995], 3 * n) / n] if n else
                      [float("nan")] * 2)
    d["misfit"] = float(np.median(sub["misfit"])) if n else float("nan")
    d["converged_share"] = float(np.mean(keep))
    d["converged_runs"] = n
    d["runs"] = int(keep.size)
    d["plausible_share"] = float(np.mean(f["plausible"]))
    sig = np.median(sub["scale_sigma_m"], axis=0) if n else [float("nan")] * 2
    d["main_scale_sigma_m"], d["spread_scale_sigma_m"] = float(sig[0]), float(sig[1])
    b = res.model_bias
    d["main_scale_bias_m"] = b.get("main_scale_m", float("nan"))
    d["spread_scale_bias_m"] = b.get("spread_scale_m", float("nan"))
    d["model_bias"] = dict(b)
    if res.runs > 1 and n:
        d["centroid_error_p90_m"] = float(np.percentile(res.errors["fit"][keep, -1], 90))
    return d


def summarise(res):
    """summary.json's content (module notes); medians over runs where there are several."""
    case = res.case
    out = {"case": case.to_dict(), "runs": res.runs, "outlier_samples": res.outlier_samples,
           "filters": {}}
    settle = settle_samples(res.times.size)
    out["settle_samples"] = settle
    for name, err in res.errors.items():
        track = name != "fit"  # a filter's or Euler's track; the batch fit: one estimate
        with np.errstate(invalid="ignore"):  # Euler is NaN where G is singular
            d = {"centroid_error_m": float(np.nanmedian(err[:, -1]))}
            if track:
                d["peak_error_m"] = float(np.nanmedian(np.nanmax(err[:, settle:], axis=1)))
        if name == "fit":
            d = _fit_summary(res, d)
        elif name in res.final:
            d.update(_scores(res.final[name], res.nees[name][:, settle:], case.target.main_scale))
        else:
            d["median_condition_number"] = float(np.median(res.euler_cond))
            d["flagged_share"] = float(np.mean(res.euler_cond > EULER_FLAG_COND))
        if res.runs > 1 and name != "fit":
            with np.errstate(invalid="ignore"):
                d["centroid_error_p90_m"] = float(np.nanpercentile(err[:, -1], 90))
        out["filters"][name] = d
    return out
