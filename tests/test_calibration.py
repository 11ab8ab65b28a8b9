"""Ship magnetometer calibration (seed 004, spec §9): observability, estimators, data, CLI.

Noise model of seed 004's simulation: "random errors of at most 100 nT" on B and "of at most
0.05°" on each angle. A maximum is a bound, which a Gaussian does not have, so the errors are
drawn uniform in ±100 nT and ±0.05° (standard deviations 100/√3 nT and 0.05°/√3); the bounds
use those standard deviations.
"""

from __future__ import annotations

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import core
from core import calibration as cal
from core.calibration import model

ROOT = Path(__file__).resolve().parents[1]
SIM = core.SEED004_SIMULATION
BE_SIM = np.array(SIM["be"])
K_SIM = np.array(SIM["K"])
BP_SIM = np.array(SIM["Bp"])
TRUTH = np.r_[K_SIM.ravel(), BP_SIM]
BE_T1 = np.array(core.SEED004_TABLE1["be"])

# Seed 004's Table 1 as the paper prints it (digit groups separated by spaces, minus signs "−"),
# copied from the seed text: an independent transcription to check data/seed004_table1.csv.
TABLE1_PRINTED = """
1 4 206 25 290 36 913 4.712 39 0.025 22 −0.004 26
2 −30 595 −2 785 40 620 3.141 59 0.024 73 −0.003 02
3 2 478 −31 825 43 890 1.570 80 0.023 21 −0.002 62
4 37 118 −3 690 40 110 0.000 00 0.023 09 −0.003 91
5 37 485 −9 719 39 480 0.000 00 −0.174 01 −0.014 15
6 2 608 −36 985 36 580 1.570 80 −0.173 47 −0.012 90
7 −30 197 −8 205 41 110 3.14159 −0.171 83 −0.013 28
8 4 761 19 020 43 985 4.712 39 −0.171 27 −0.014 54
9 37 811 2 408 37 845 0.000 00 0.222 70 −0.021 92
10 4 514 30 860 28 158 4.712 39 0.224 57 −0.022 46
11 −29 836 3 038 39 796 3.141 59 0.223 66 −0.022 48
12 3 615 −25 322 49 387 1.570 80 0.222 16 −0.022 11
"""


def _parse_printed(text):
    """Rebuild numbers from the printed groups: an integer is a group of 1–3 digits (optionally
    signed) followed by 3-digit groups; a decimal is d.ddd followed by one 2-digit group (or
    written in one piece, as row 7's 3.14159)."""
    rows = []
    for line in text.strip().splitlines():
        toks = line.replace("−", "-").split()[1:]
        vals, i = [], 0
        while i < len(toks):
            t = toks[i]
            i += 1
            if "." in t:
                if len(t.split(".")[1]) == 3:
                    t += toks[i]
                    i += 1
            else:
                while i < len(toks) and len(toks[i]) == 3 and toks[i].isdigit() and len(vals) < 3:
                    t += toks[i]
                    i += 1
            vals.append(float(t))
        rows.append(vals)
    return np.array(rows)


# --------------------------------------------------------------------------- model
def test_attitude_matrix_is_seed004_eq2():
    """Eq. (2) written out by hand: R_pitch(φ) R_roll(θ) R_heading(ψ)."""
    psi, th, ph = 0.7, -0.2, 0.1
    c, s = np.cos, np.sin
    Rph = np.array([[c(ph), 0, s(ph)], [0, 1, 0], [-s(ph), 0, c(ph)]])
    Rth = np.array([[1, 0, 0], [0, c(th), s(th)], [0, -s(th), c(th)]])
    Rps = np.array([[c(psi), s(psi), 0], [-s(psi), c(psi), 0], [0, 0, 1]])
    A = core.attitude_matrix([psi, th, ph])
    np.testing.assert_allclose(A, Rph @ Rth @ Rps, atol=1e-15)
    # every convention is a proper rotation; broadcasting over leading axes
    att = np.random.default_rng(0).uniform(-3, 3, (5, 4, 3))
    for conv in core.CONVENTIONS:
        A = core.attitude_matrix(att, convention=conv)
        assert A.shape == (5, 4, 3, 3)
        np.testing.assert_allclose(A @ np.swapaxes(A, -1, -2), np.broadcast_to(np.eye(3), A.shape),
                                   atol=1e-14)
        np.testing.assert_allclose(np.linalg.det(A), 1.0, atol=1e-14)


def test_heading_is_clockwise_from_north():
    """Heading east (π/2, as Table 1 has it): the bow sensor reads the east component, the
    starboard sensor minus the north one; the vertical stays."""
    B = core.ship_field(np.eye(3), [0, 0, 0], [[np.pi / 2, 0, 0]], BE_T1)
    np.testing.assert_allclose(B[0], [BE_T1[1], -BE_T1[0], BE_T1[2]], atol=1e-9)


def test_attitude_derivative_matches_complex_step():
    """dA/d(angle) used by the angle-noise CRLB, against complex-step differentiation of the
    factors written independently here (eq. (2))."""
    def A_of(p, t, f):
        c, s = np.cos, np.sin
        z = np.zeros((), dtype=complex)
        Rph = np.array([[c(f), z, s(f)], [z, z + 1, z], [-s(f), z, c(f)]])
        Rth = np.array([[z + 1, z, z], [z, c(t), s(t)], [z, -s(t), c(t)]])
        Rps = np.array([[c(p), s(p), z], [-s(p), c(p), z], [z, z, z + 1]])
        return Rph @ Rth @ Rps
    a = np.array([1.1, 0.3, -0.2])
    _, dA = model._attitude(a, core.CONVENTIONS["seed004"])
    h = 1e-30
    for k in range(3):
        e = np.zeros(3, dtype=complex)
        e[k] = 1j * h
        np.testing.assert_allclose(dA[k], A_of(*(a + e)).imag / h, atol=1e-14)


def test_gamma_is_the_derivative_of_the_readings():
    """B is linear in the 12 coefficients: Γ's columns equal the change of B per unit change of
    each coefficient (central difference of step 1, exact up to round-off)."""
    att = core.heading_manoeuvre(roll_deg=12, pitch_deg=4, n_attitudes=7)
    G = core.calibration_gamma(att, BE_SIM)
    assert G.shape == (21, 12)
    for j in range(12):
        d = np.zeros(12)
        d[j] = 1.0
        up = core.ship_field((TRUTH + d)[:9].reshape(3, 3), (TRUTH + d)[9:], att, BE_SIM)
        dn = core.ship_field((TRUTH - d)[:9].reshape(3, 3), (TRUTH - d)[9:], att, BE_SIM)
        np.testing.assert_allclose(((up - dn) / 2).ravel(), G[:, j], atol=1e-9)


# --------------------------------------------------------------------------- observability
def test_four_level_headings_rank_9_k3_with_bp():
    obs = core.calibration_observability(core.level_headings(), BE_SIM)
    assert obs.rank == 9
    assert obs.null_directions.shape == (3, 12)
    # each null direction only moves k_i3 and Bp_i, with δBp_i = −Be_z · δk_i3 (all i)
    k3, bp = [2, 5, 8], [9, 10, 11]
    others = [j for j in range(12) if j not in k3 + bp]
    n = obs.null_directions
    assert np.abs(n[:, others]).max() < 1e-12 * np.abs(n).max()
    np.testing.assert_allclose(n[:, bp], -BE_SIM[2] * n[:, k3], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(core.calibration_gamma(core.level_headings(), BE_SIM) @ n.T, 0,
                               atol=1e-9)
    assert len(obs.descriptions) == 1
    assert obs.descriptions[0].startswith("K's third column and Bp cannot be told apart")
    assert "−35000 nT" in obs.descriptions[0]
    # the four-heading method measures only K's first two columns (seed 004, §0)
    assert obs.observable.tolist() == [True, True, False] * 3 + [False] * 3
    crlb = core.calibration_crlb(core.level_headings(), BE_SIM, noise_nt=100)
    assert np.isfinite(crlb[obs.observable]).all() and np.isinf(crlb[~obs.observable]).all()
    assert obs.singular_values[-1] < 1e-15 and obs.singular_values[8] > 0.1
    # closed form: k_i3·Be_z + Bp_i is one parameter, so K's first two columns have the
    # variance of a fit with columns (h1, h2, 1)
    C3 = core.design_rows(core.level_headings(), BE_SIM)[:, [0, 1, 3]]
    np.testing.assert_allclose(crlb[[0, 1]], 100 * np.sqrt(np.diag(np.linalg.inv(C3.T @ C3))[:2]),
                               rtol=1e-9)


def test_any_level_headings_and_constant_heel_stay_rank_9():
    """Eight level headings, or a constant roll on all four: the ship-frame field vectors stay
    on one plane, so still rank 9 (a heel that does not vary does not help)."""
    assert core.calibration_observability(core.level_headings(np.arange(0, 360, 45)), BE_SIM).rank == 9
    heel = core.level_headings()
    heel[:, 1] = np.deg2rad(8.0)
    assert core.calibration_observability(heel, BE_SIM).rank == 9


@pytest.mark.parametrize("roll, pitch", [(10.0, 5.0), (10.0, 0.0), (0.0, 5.0), (0.01, 0.0)])
def test_roll_and_pitch_give_rank_12(roll, pitch):
    att = core.heading_manoeuvre(roll_deg=roll, pitch_deg=pitch, n_attitudes=4)
    obs = core.calibration_observability(att, BE_SIM)
    assert obs.rank == 12 and obs.descriptions == () and obs.observable.all()
    # the smallest scaled singular value sits far above CAL_RANK_RTOL even for 0.01°
    assert obs.singular_values[-1] > 1e3 * core.CAL_RANK_RTOL
    assert np.isfinite(core.calibration_crlb(att, BE_SIM, noise_nt=100)).all()


def test_table1_manoeuvre_is_rank_12():
    _, att = core.seed004_table1()
    assert core.calibration_observability(att, BE_T1).rank == 12


def test_crlb_scales_with_noise_and_matches_lsq_without_angle_noise():
    att = core.heading_manoeuvre(roll_deg=15, pitch_deg=5, n_attitudes=12)
    s1 = core.calibration_crlb(att, BE_SIM, noise_nt=10)
    s2 = core.calibration_crlb(att, BE_SIM, noise_nt=100)
    np.testing.assert_allclose(s2, 10 * s1, rtol=1e-9)
    cov_l = core.calibration_covariance(att, BE_SIM, noise_nt=100, estimator="lsq")
    np.testing.assert_allclose(np.sqrt(np.diag(cov_l)), s2, rtol=1e-9)
    # closed form for Bp: each axis's 4 × 4 information C ᵀC / σ²
    C = core.design_rows(att, BE_SIM)
    np.testing.assert_allclose(s2[9], 100 * np.sqrt(np.linalg.inv(C.T @ C)[3, 3]), rtol=1e-9)


# --------------------------------------------------------------------------- estimators
def test_lsq_noise_free_recovers_K_and_Bp():
    """Tolerance: 1e-9 on K (dimensionless) and 1e-9 · |Be| on Bp (5e-5 nT); float64 round-off
    on 35 000 nT readings is ~1e-11 relative."""
    rng = np.random.default_rng(1)
    for att in (core.heading_manoeuvre(roll_deg=10, pitch_deg=5, n_attitudes=12),
                core.random_attitudes(12, rng), core.seed004_table1()[1]):
        B = core.ship_field(K_SIM, BP_SIM, att, BE_SIM)
        r = core.lsq_calibrate(B, att, BE_SIM)
        assert r.rank == 12
        np.testing.assert_allclose(r.K, K_SIM, rtol=0, atol=1e-9)
        np.testing.assert_allclose(r.Bp, BP_SIM, rtol=0, atol=1e-9 * np.linalg.norm(BE_SIM))
        assert r.residual_rms_nt < 1e-6


def test_lsq_broadcasts_over_runs():
    rng = np.random.default_rng(2)
    att = core.random_attitudes(12, rng, size=(3,))
    B, rec = core.simulate_ship_data(K_SIM, BP_SIM, att, BE_SIM, rng, noise_nt=100)
    r = core.lsq_calibrate(B, rec, BE_SIM)
    for k in range(3):
        one = core.lsq_calibrate(B[k], rec[k], BE_SIM)
        np.testing.assert_allclose(r.K[k], one.K, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(r.Bp[k], one.Bp, rtol=1e-12)


def test_kalman_matches_closed_form_posterior():
    """With Q = 0, seed 004's recursion must equal the Bayesian posterior in information form,
    x = (P0⁻¹ + Σ CᵀC/σ²)⁻¹ (P0⁻¹ x0 + Σ Cᵀ y/σ²), written out independently here."""
    rng = np.random.default_rng(3)
    att = core.random_attitudes(12, rng)
    B, rec = core.simulate_ship_data(K_SIM, BP_SIM, att, BE_SIM, rng, noise_nt=100)
    P0 = np.array([0.5, 0.5, 0.5, 2000.0 ** 2])
    x0 = np.r_[np.eye(3), [[100.0, 0.0, -100.0]]]
    sig = 60.0
    M = 30  # 2.5 passes: readings 0–11, 0–11, 0–5
    r = core.kalman_calibrate(B, rec, BE_SIM, sigma_nt=sig, iterations=M, P0=P0, x0=x0)
    C = core.design_rows(rec, BE_SIM)
    idx = np.arange(M) % 12
    info = np.diag(1 / P0) + C[idx].T @ C[idx] / sig ** 2
    x = np.linalg.solve(info, np.diag(1 / P0) @ x0 + C[idx].T @ B[idx] / sig ** 2)
    np.testing.assert_allclose(r.history[-1], x, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(r.P_diag[-1], np.diag(np.linalg.inv(info)), rtol=1e-6)
    assert r.history.shape == (M + 1, 4, 3) and r.coefficients.shape == (M + 1, 12)
    np.testing.assert_allclose(r.history[0], x0)


def test_kalman_huge_prior_no_process_noise_converges_to_lsq():
    """P(0) with standard deviations 1000 × the coefficients' scale (K ~ 1, Bp ~ |Be|), Q = 0:
    the prior's pull after 10 passes is ~ (CRLB / prior std)² ≲ 1e-12 of the data's; the
    tolerance is 1e-4 CRLB standard deviations (float64 covariance form, see the docstring)."""
    rng = np.random.default_rng(5)
    att = core.random_attitudes(12, rng)
    B, rec = core.simulate_ship_data(K_SIM, BP_SIM, att, BE_SIM, rng, noise_nt=100,
                                     angle_noise_deg=0.05)
    lsq = core.lsq_calibrate(B, rec, BE_SIM)
    big = 1e3 ** 2
    P0 = (big, big, big, big * float(BE_SIM @ BE_SIM))
    r = core.kalman_calibrate(B, rec, BE_SIM, sigma_nt=60, iterations=120, P0=P0, Q=0.0)
    crlb = core.calibration_crlb(rec, BE_SIM, noise_nt=60)
    err = np.abs(r.coefficients[-1] - np.r_[lsq.K.ravel(), lsq.Bp]) / crlb
    assert err.max() < 1e-4


def test_kalman_error_within_crlb_over_400_runs():
    """Seed 004's simulation (12 attitudes drawn in its ranges, uniform errors ±100 nT and
    ±0.05°) repeated with fresh errors 400 times; the filter (x(0) = 0, default P(0), Q = 0,
    σ = 100/√3 nT, 5 passes over the 12 readings).

    Normalised errors z = (x̂ − x) / σ with σ from the least-squares covariance (the filter's
    estimate is the least-squares one up to the prior's ~0.1 % pull; with the angle errors it
    is ≤ 1 % above the CRLB here, checked below): per coefficient the mean must be within
    ±0.2 (4 standard errors, 1/√400 = 0.05) and the variance in [0.7, 1.3] (its standard
    error is ~√(2/400) = 0.07 for near-Gaussian z); the mean Mahalanobis distance within
    12 ± 1.25 (5 standard errors, √(24/400)). The CRLB-normalised variance must be ≥ 0.7 (no
    linear estimator beats the bound) and ≤ 1.5 ("within a few CRLB σ")."""
    rng = np.random.default_rng(2024)
    att = core.random_attitudes(12, rng)
    runs = 400
    B, rec = core.simulate_ship_data(K_SIM, BP_SIM, np.broadcast_to(att, (runs, 12, 3)), BE_SIM,
                                     rng, noise_nt=100, angle_noise_deg=0.05)
    r = core.kalman_calibrate(B, rec, BE_SIM, sigma_nt=100 / np.sqrt(3), iterations=60)
    err = r.coefficients[:, -1] - TRUTH  # (runs, 12)
    kw = dict(noise_nt=100 / np.sqrt(3), angle_noise_rad=np.deg2rad(0.05) / np.sqrt(3), K=K_SIM)
    cov = core.calibration_covariance(att, BE_SIM, estimator="lsq", **kw)
    crlb = np.sqrt(np.diag(core.calibration_covariance(att, BE_SIM, **kw)))
    assert (np.sqrt(np.diag(cov)) / crlb).max() < 1.01
    z = err / np.sqrt(np.diag(cov))
    assert np.abs(z.mean(axis=0)).max() < 0.2, z.mean(axis=0)
    assert 0.7 < z.var(axis=0).min() and z.var(axis=0).max() < 1.3, z.var(axis=0)
    d2 = np.einsum("ri,ij,rj->r", err, np.linalg.inv(cov), err)
    assert abs(d2.mean() - 12) < 1.25, d2.mean()
    zc = (err / crlb).var(axis=0)
    assert zc.min() > 0.7 and zc.max() < 1.5, zc


def test_geomagnetic_solution_inverts_the_model():
    att = core.heading_manoeuvre(roll_deg=10, pitch_deg=5, n_attitudes=12)
    B = core.ship_field(K_SIM, BP_SIM, att, BE_SIM)
    be_hat = core.geomagnetic_solution(B, att, K_SIM, BP_SIM)
    np.testing.assert_allclose(be_hat, np.broadcast_to(BE_SIM, be_hat.shape), atol=1e-9)
    err = core.geomagnetic_error(be_hat + [30.0, -40.0, 0.0], BE_SIM)
    assert err.vector_rms_nt == pytest.approx(50.0)
    assert err.rms_nt == pytest.approx(50.0 / np.sqrt(3))
    assert err.max_rel == pytest.approx(40.0 / np.linalg.norm(BE_SIM))


@pytest.mark.parametrize("call, match", [
    (lambda: core.ship_field(np.eye(3), [0, 0, 0], [[90, 0, 0]], BE_SIM), "radians"),
    (lambda: core.ship_field(np.eye(3), [0, 0], [[0, 0, 0]], BE_SIM), "Bp must be a vector"),
    (lambda: core.design_rows([[0, 0, 0]], [0, 0, 0]), "must not be zero"),
    (lambda: core.lsq_calibrate(np.zeros((3, 3)), np.zeros((3, 3)), BE_SIM), "at least 4"),
    (lambda: core.calibration_crlb(core.level_headings(), BE_SIM, noise_nt=0), "noise_nt"),
    (lambda: core.kalman_calibrate(np.zeros((4, 3)), core.level_headings(), BE_SIM, sigma_nt=1,
                                   iterations=0), "iterations"),
    (lambda: core.kalman_calibrate(np.zeros((4, 3)), core.level_headings(), BE_SIM, sigma_nt=1,
                                   P0=[1, 1, 1, -1]), "P0"),
    (lambda: core.attitude_matrix([0, 0, 0], convention="xyz"), "convention"),
    (lambda: core.heading_manoeuvre(n_attitudes=0), "n_attitudes"),
    (lambda: core.geomagnetic_solution(np.zeros((4, 3)), core.level_headings(), np.zeros((3, 3)),
                                       [0, 0, 0]), "invertible"),
])
def test_bad_input_raises_value_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()


# --------------------------------------------------------------------------- data
def test_table1_csv_matches_the_printed_table_and_round_trips():
    B, att = core.seed004_table1()
    printed = _parse_printed(TABLE1_PRINTED)
    assert printed.shape == (12, 6)
    np.testing.assert_array_equal(np.c_[B, att], printed)
    # round trip: write the parsed table, read it back
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(cal.CSV_COLUMNS)
    w.writerows(np.c_[B, att].tolist())
    B2, att2 = core.parse_attitude_csv(buf.getvalue())
    np.testing.assert_array_equal(B2, B)
    np.testing.assert_array_equal(att2, att)
    assert Path(cal.seed004_table1_path()) == ROOT / "data" / "seed004_table1.csv"


@pytest.mark.parametrize("text, match", [
    ("B1,B2,psi,theta,phi\n1,2,0,0,0\n", "lacks column\\(s\\) B3"),
    ("B1,B2,B3,psi,theta,phi\n1,2,x,0,0,0\n1,2,3,0,0,0\n1,2,3,0,0,0\n1,2,3,0,0,0\n",
     "line 2, column B3: 'x' is not a number"),
    ("B1,B2,B3,psi,theta,phi\n" + "1,2,3,90,0,0\n" * 4, "exceeds 2π.*radians"),
    ("B1,B2,B3,psi,theta,phi\n" + "1,2,3,0,0,0\n" * 3, "need at least 4|at least 4"),
    ("", "empty"),
])
def test_csv_bad_input(text, match):
    with pytest.raises(ValueError, match=match):
        core.parse_attitude_csv(text)


# --------------------------------------------------------------------------- CLI
def _cli(*args):
    return subprocess.Popen([sys.executable, "-m", "core.calibration", *map(str, args)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_cli_json_on_table1():
    p = _cli("data/seed004_table1.csv", "--be", "34425,1961,35898", "--json")
    out, err = p.communicate(timeout=120)
    assert p.returncode == 0, err
    assert err == ""
    r = json.loads(out)
    for key in ("K", "Bp", "K_lsq", "Bp_lsq", "rank", "be_rms_nT", "crlb"):
        assert key in r
    assert r["rank"] == 12 and np.shape(r["K"]) == (3, 3) and np.shape(r["Bp"]) == (3,)
    B, att = core.seed004_table1()
    lsq = core.lsq_calibrate(B, att, BE_T1)
    np.testing.assert_allclose(r["K_lsq"], lsq.K, rtol=1e-12)
    # 50 passes with the default prior: the filter sits within 0.05 CRLB σ of least squares
    crlb = np.array([r["crlb"][c] for c in core.COEFFICIENTS])
    kal = np.r_[np.ravel(r["K"]), r["Bp"]]
    assert (np.abs(kal - np.r_[lsq.K.ravel(), lsq.Bp]) / crlb).max() < 0.05


def test_cli_bad_input(tmp_path):
    good = (ROOT / "data" / "seed004_table1.csv").read_text()
    files = {
        "missing": "B1,B2,psi,theta,phi\n1,2,0,0,0\n",
        "text": good.replace("4206", "4206x", 1),
        "degrees": good.replace("4.71239", "270", 1),
        "few": "\n".join(good.splitlines()[:4]) + "\n",
    }
    cases = []
    for name, text in files.items():
        f = tmp_path / f"{name}.csv"
        f.write_text(text)
        cases.append((f, "34425,1961,35898"))
    cases += [(ROOT / "data" / "seed004_table1.csv", "34425,1961"),
              (ROOT / "data" / "seed004_table1.csv", "a,b,c"),
              (tmp_path / "nonexistent.csv", "34425,1961,35898")]
    expect = ["lacks column(s) B3", "line 2, column B1: '4206x' is not a number",
              "exceeds 2π", "has 3 attitude(s)", "--be must be three", "--be must be three",
              "cannot read"]
    procs = [_cli(f, "--be", be) for f, be in cases]  # run concurrently: each pays the imports
    for p, msg in zip(procs, expect):
        out, err = p.communicate(timeout=120)
        assert p.returncode == 2, (msg, err)
        assert msg in err and "Traceback" not in err and out == ""
        assert len(err.strip().splitlines()) == 1


# --------------------------------------------------------------------------- report section
def test_report_section_numbers():
    from paper import calibration as pc

    n = pc.numbers(mc_runs=20)
    assert n["four"]["rank"] == 9 and n["four"]["rank_roll_pitch"] == 12
    assert n["four"]["rank_constant_heel"] == 9
    t = n["table1"]
    # least squares has the smallest residual of any (K, Bp) under its convention
    assert t["lsq_fit"][0] <= t["paper_fit"][0] and t["lsq_fit"][0] <= t["kal_fit"][0] + 1e-6
    for label, lsq_fit, paper_fit in t["conventions"]:
        assert lsq_fit[0] <= paper_fit[0] + 1e-9, label
    # the paper's estimate is consistent with least squares given the residual noise
    assert np.abs(t["z"]).max() < 3
    text = pc.section(n)
    assert "rank Γ = **9** of 12" in text and "K's third column and Bp cannot be told apart" in text
    for c in core.CONVENTIONS:
        assert f"| `{c}` |" in text
