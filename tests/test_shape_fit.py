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


def test_plausible_means_one_target_beside_the_track():
    """fit.plausible against hand-placed dipoles and a distance written here: the track is the
    x axis from −40 to +40 m (seed 003's pass moved to y = z = 0). Dipoles 1.5 m about a centroid
    7 m off the track: plausible; one dipole moved 30 m out (farther from the centroid than the
    centroid is from the track): not; a centroid beyond the track's end is measured to the end
    (the track is a segment, not a line); NaN: not."""
    from core.shape.fit import plausible, track_distance

    st = np.column_stack([np.linspace(-40, 40, 81), np.zeros(81), np.zeros(81)])
    pos = np.array([[0, 7, -1.5], [0, 7, -0.5], [0, 7, 0.5], [0, 7, 1.5]], float)
    x = np.r_[pos.ravel(), 1.0, 0.0, 0.0]
    assert track_distance(pos.mean(axis=0), st) == pytest.approx(7.0)
    assert track_distance([50.0, 0.0, 3.0], st) == pytest.approx(np.hypot(10.0, 3.0))
    assert plausible(x, st)
    far = pos.copy()
    far[3] = [0, 37, 0]  # the centroid moves to 14.5 m from the track; this dipole is 22.5 m from it
    x_far = np.r_[far.ravel(), 1.0, 0.0, 0.0]
    c = far.mean(axis=0)
    assert np.linalg.norm(far - c, axis=1).max() > track_distance(c, st)  # the case being tested
    assert not plausible(x_far, st)
    x_nan = x.copy()
    x_nan[0] = np.nan
    assert not plausible(x_nan, st)


def test_a_far_local_minimum_is_not_kept_when_a_start_reaches_a_plausible_one():
    """Issue 46: Fig. 5's one-sample row, seed 0, pass 2 ended as a "converged" fit with a dipole
    146 m from the track and a span of 214 m (both starts' lowest cost). Among the starts the
    plausible fit is now kept: that pass reads the cylinder (main scale within 0.3 m of 3 m,
    axis within 10°) and every pass of the three is plausible and converged. Passes are drawn per
    run (rng([seed, r])), so 3 runs reproduce the 24-run batch's pass 2."""
    row = CASES["seed003-fig5"][1][1]
    assert row.comparison and row.lag == 0
    res = run_case(row, runs=3, seed=0)
    f = res.final["fit"]
    assert f["plausible"].all() and f["converged"].all()
    assert abs(f["main_scale_m"][2] - 3.0) < 0.3 and f["axis_error_deg"][2] < 10.0


def test_the_fit_reports_its_model_bias_beside_its_sigma():
    """The bias of fitting 4 dipoles to the cylinder's 2400 cells (model_bias: the fit of the
    noise-free readings) is what the noisy fits scatter about: over 12 passes of Fig. 4 (seed 5)
    the median signed error of each read is within 3 σ/√12·1.25 (the median's standard error) +
    2 mm of it, while the bias is ≥ 10× the fit's σ (the issue's 11–35×); the σ is the fits'
    own (delta method through the covariance)."""
    row = CASES["seed003-fig4"][1][0]
    res = run_case(row, runs=12, seed=5)
    s = res.summary["filters"]["fit"]
    f = res.final["fit"]
    assert s["main_scale_bias_m"] == pytest.approx(-0.071, abs=0.005)  # docs/shape.md
    assert s["spread_scale_bias_m"] == pytest.approx(-0.038, abs=0.005)
    for read, bias, sig in (("main_scale_m", s["main_scale_bias_m"], s["main_scale_sigma_m"]),
                            ("spread_scale_m", s["spread_scale_bias_m"], s["spread_scale_sigma_m"])):
        err = np.median(f[read] - 3.0)
        assert abs(err - bias) <= 3 * 1.25 * sig / np.sqrt(12) + 0.002, (read, err, bias, sig)
        assert abs(bias) >= 10 * sig, (read, bias, sig)
