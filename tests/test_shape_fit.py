"""The batch fit (core.shape.fit): the optimiser on a model-matched truth, its robustness, its
Jacobian, and seed 003's accuracy targets (issue 37 item 2)."""

import numpy as np
import pytest
from scipy import stats

from core.shape import model as md
from core.shape.cases import CASES
from core.shape.experiment import run_case
from core.shape.fit import fit_pass, huber_efficiency
from core.shape.targets import Pass

TRACK = Pass()
AXIS = np.array([0.73919892, 0.28033009, 0.61237244])
X_TRUE = np.r_[np.outer((np.arange(4) + 0.5) / 4 * 3 - 1.5, AXIS).ravel(), 600.0 * np.array([-3, 1, 5])]


def test_huber_efficiency_is_the_95_percent_of_u_1345():
    assert huber_efficiency(1.345) == pytest.approx(1 / 0.95, rel=2e-3)
    assert huber_efficiency(50.0) == pytest.approx(1.0, abs=1e-12)  # least squares


def test_pass_jacobian_with_the_array_matches_central_differences():
    """The fit's model (the 0.5 m array, every sample once) against central differences of its
    own readings (h = 1e-4 m / 1e-2 A·m²; truncation ~(h/r)² ~ 1e-10 relative; 1e-6 of the column)."""
    mdl = md.DipoleModel(TRACK.positions, baseline=0.5)
    h0, J = mdl.pass_jacobian(X_TRUE)
    np.testing.assert_allclose(h0, mdl.tensor5(X_TRUE, TRACK.positions), rtol=1e-12, atol=0)
    steps = np.r_[np.full(12, 1e-4), np.full(3, 1e-2)]
    for i in range(15):
        e = np.zeros(15)
        e[i] = steps[i]
        fd = (mdl.tensor5(X_TRUE + e, TRACK.positions) - mdl.tensor5(X_TRUE - e, TRACK.positions)).ravel() / (2 * steps[i])
        np.testing.assert_allclose(J[:, i], fd, rtol=0, atol=1e-6 * np.abs(J[:, i]).max())


def test_fit_recovers_a_model_matched_truth_and_ignores_outliers():
    """A truth that is itself 4 dipoles: noise-free readings from a start 0.3 m / 20 % off give
    the truth back to 1e-6 m; with noise (σ 0.01 nT/m), 40 passes, the centroid NEES with the
    Fisher covariance lies in its two-sided 99 % band; 500 σ outliers on 3 samples move the
    Huber fit by less than 3 σ of its own bound, least squares (u = ∞) by far more."""
    rng = np.random.default_rng(5)
    z0 = md.DipoleModel(TRACK.positions).tensor5(X_TRUE, TRACK.positions)
    start = X_TRUE + np.r_[0.3 * rng.standard_normal(12), 0.2 * X_TRUE[12:]]
    f = fit_pass(z0, TRACK.positions, start, 0.01)
    assert f.converged and np.abs(f.x[:12] - X_TRUE[:12]).max() < 1e-6
    A = np.kron(np.ones((1, 4)) / 4, np.eye(3))
    nees = []
    for r in range(40):
        z = z0 + 0.01 * rng.standard_normal(z0.shape)
        f = fit_pass(z, TRACK.positions, X_TRUE, 0.01)
        e = A @ (f.x[:12] - X_TRUE[:12])
        nees.append(e @ np.linalg.solve(A @ f.cov[:12, :12] @ A.T, e))
    lo, hi = stats.chi2.ppf([0.005, 0.995], 3 * 40) / 40
    assert lo < np.mean(nees) < hi, np.mean(nees)
    z = z0 + 0.01 * rng.standard_normal(z0.shape)
    clean = fit_pass(z, TRACK.positions, X_TRUE, 0.01)
    z[[20, 30, 40]] += 5.0 * np.sign(z0[[20, 30, 40]])
    robust = fit_pass(z, TRACK.positions, X_TRUE, 0.01)
    ls = fit_pass(z, TRACK.positions, X_TRUE, 0.01, u=np.inf)
    sd = np.sqrt(np.diag(clean.cov)[:12])
    assert np.abs((robust.x[:12] - clean.x[:12]) / sd).max() < 3
    assert np.abs((ls.x[:12] - clean.x[:12]) / sd).max() > 30
    assert robust.downweighted >= 15  # the 3 × 5 outlying components


@pytest.mark.parametrize("case, factor", [("seed003-fig4", 1.0), ("seed003-fig5", 1.5)])
def test_fit_meets_the_papers_accuracy_on_figs_4_and_5(case, factor):
    """Seed 003's pass and noise, 20 passes (seed 3; the case's first row: its filters give the
    starts): median axis error ≤ 2° and main scale (span read) within 0.15 m — × 1.5 with Fig. 5's
    outliers — the issue's targets; measured 0.023° / 0.073 m and 0.020° / 0.078 m, so the
    margin is wide and 20 passes keep the medians stable (each pass's axis error is 0.00–0.04°).
    The fit's centroid NEES (mean over 20 passes, 3 dof each, covariance scaled by its residuals'
    variance factor) lies in its two-sided 99 % chi-square band: measured 2.8 and 2.5."""
    row = CASES[case][1][0]
    res = run_case(row, runs=20, seed=3)
    f = res.final["fit"]
    assert np.all(f["kind"] == "line")
    assert np.median(f["axis_error_deg"]) <= 2.0 * factor, np.median(f["axis_error_deg"])
    assert np.median(np.abs(f["main_scale_m"] - 3.0)) <= 0.15 * factor
    s = res.summary["filters"]["fit"]
    lo, hi = s["nees_band"]
    assert lo < s["nees"] < hi, (s["nees"], lo, hi)
    assert lo == pytest.approx(stats.chi2.ppf(0.005, 60) / 20) and "peak_error_m" not in s
