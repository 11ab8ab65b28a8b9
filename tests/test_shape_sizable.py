"""The main scale's bound in its two reads, the `sizable` verdict against the Monte-Carlo of the
filters and the batch fit, and the planner's command line (issue 37 items 3, 4)."""

import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from core.cli import shape as cli
from core.shape import bound as bd
from core.shape import model as md
from core.shape.targets import Pass, Target

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _reads(pos):
    """The two reads of a line's main scale, written here from their definitions (not pca.py):
    span N/(N−1)·(max − min of the projections on u1); second moment N·√(12 λ1'/(N² − 1)) with
    λ1' the largest eigenvalue of the 1/N covariance (the spec's formula)."""
    n = len(pos)
    d = pos - pos.mean(axis=0)
    w, V = np.linalg.eigh(d.T @ d / n)
    u1 = V[:, -1]
    p = pos @ u1
    return n / (n - 1) * (p.max() - p.min()), n * np.sqrt(12 * w[-1] / (n * n - 1))


@pytest.mark.parametrize("offset", [5.0, 10.0])
def test_both_reads_bounds_match_an_independent_fisher_matrix(offset):
    """The 15-state Fisher matrix built here by central differences of core.gradient_tensor (the
    4 dipoles at the target's representation, σ = 0.01 nT/m, the pass at offset = height), and
    the two reads' σ by the delta method through the reads written above, equal core.shape.bound's.
    Steps 1e-5 m and 1e-5 relative on the moment: truncation ~(h/r)² ~ 1e-12, round-off ~1e-16 |G|/h
    ~ 1e-11 relative per column; the 15-state matrix's conditioning (~1e9 at 14 m) amplifies them
    into the inverse: 1e-3 relative covers it with room and still catches a wrong read (the two
    reads differ by 5× and 21×)."""
    from core import gradient_tensor

    t = Target()
    track = Pass(start=(-40.0, offset, -offset))
    b = bd.shape_bound(t, track)
    x0 = bd.representation(t)
    i, j = zip(*md.G_COMPONENTS)

    def g5(x):
        st = np.zeros((4, 8))
        st[:, :3], st[:, 5:] = x[:12].reshape(4, 3), x[12:]
        return gradient_tensor(st, track.positions).sum(axis=0)[:, i, j].ravel()

    steps = np.r_[np.full(12, 1e-5), 1e-5 * np.abs(x0[12:])]
    D = np.stack([(g5(x0 + s * e) - g5(x0 - s * e)) / (2 * s) for e, s in zip(np.eye(15), steps)], -1)
    C = np.linalg.inv(D.T @ D / 0.01**2)
    h = 1e-6
    grad = np.zeros((2, 15))
    for k in range(12):
        e = np.zeros(15)
        e[k] = h
        grad[:, k] = (np.array(_reads((x0 + e)[:12].reshape(4, 3))) - _reads((x0 - e)[:12].reshape(4, 3))) / (2 * h)
    span, second = np.sqrt(np.einsum("ri,ij,rj->r", grad, C, grad))
    assert b.main_scale_m == pytest.approx(span, rel=1e-3)
    assert b.spread_main_scale_m == pytest.approx(second, rel=1e-3)
    assert b.spread_main_scale_m < b.main_scale_m / 4  # the second moment sizes better


def test_the_bound_grows_as_the_spec_says_and_the_verdict_follows_the_best_read():
    """Seed 003's pass moved out: the span read's σ grows as CPA^7.6–8.8 and the second moment's
    as CPA^5.5–6 (spec §11; the slopes measured here between 15 and 30 m); `sizable` is the best
    read's σ ≤ 10 % of the main scale: at twice the paper's distance (offset 10, 10 above) the
    second-moment σ is 4.9 cm (sizable) while the span's is 1.04 m."""
    b15, b30 = bd.shape_bound_curve([15.0, 30.0])
    assert 7.6 <= np.log2(b30.main_scale_m / b15.main_scale_m) <= 8.8
    assert 5.5 <= np.log2(b30.spread_main_scale_m / b15.spread_main_scale_m) <= 6.0
    b = bd.shape_bound(Target(), Pass(start=(-40.0, 10.0, -10.0)))
    assert b.main_scale_m == pytest.approx(1.04, rel=0.01)
    assert b.spread_main_scale_m == pytest.approx(0.0489, rel=0.01)
    assert b.sizable and b.sizing == "second moment" and b.best_main_scale_m == b.spread_main_scale_m
    assert not bd.shape_bound(Target(), Pass(start=(-40.0, 35.0, -35.0))).sizable
    assert not bd.shape_bound(Target(), Pass(start=(-40.0, 60.0, -5.0))).sizable  # issue 40, defect 10


def test_sizable_at_twice_the_papers_distance_and_not_at_seven_times(tmp_path):
    """The planner's command at offset 10 m / 10 m above: sizable, and the filters' main scale
    (median of 5 passes, seed 3) within 0.5 m of 3 m; at 35 m / 35 m: not sizable, and the
    command prints the WARNING that its sizes mean nothing."""
    s = cli.run("seed003-fig4", runs=5, seed=3, offset=10.0, above=10.0, plots=False)
    assert s["sizable"] is True and s["sizing"] == "second moment"
    for name in ("ukf", "nhukf"):
        assert abs(s["filters"][name]["main_scale_m"] - 3.0) < 0.5, (name, s["filters"][name])
    assert s["truth"]["pass"]["start_m"] == [-40.0, 10.0, -10.0]
    p = subprocess.run([sys.executable, "-m", "core.shape", "--case", "seed003-fig4", "--offset", "35",
                        "--above", "35", "--lag", "5", "--out", str(tmp_path)], cwd=ROOT,
                       capture_output=True, text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin"})
    assert p.returncode == 0, p.stderr
    data = json.loads((tmp_path / "summary.json").read_text())
    assert data["sizable"] is False and data["rows"][0]["sizable"] is False
    assert set(data["bound"]) >= {"main_scale_m", "spread_main_scale_m", "rigid_main_scale_m",
                                  "best_main_scale_m", "sizable", "sizing"}
    assert set(data["filters"]["fit"]) >= {"centroid_error_m", "main_scale_m", "main_scale_error_m",
                                           "axis_error_deg", "kind", "nees", "nees_band"}
    assert "WARNING: this pass cannot size the target" in p.stdout


def test_the_sweep_writes_the_verdict_and_the_fits_shares(tmp_path):
    """The command's sweep at 16 and 24 m, 8 passes (seed 3), either side of the edge (the rule
    against a finer sweep: tests/test_shape_sizable_sweep.py): sizable at 16 m, where the
    estimators size the target (best read within 10 %, axis within 10°) and the fit sizes ≥ 80 %
    of its passes; not at 24 m, where none does and the fit sizes < 50 %. The sweep's CSV holds
    these columns, its bound equals core.shape.bound's at each closest approach, and the PNG is
    written."""
    sw = cli.cpa_sweep("seed003-fig4", 16.0, 24.0, 2, runs=8, seed=3, out=str(tmp_path))
    assert [r["sizable"] for r in sw["records"]] == [True, False]
    assert [r["verdict"] for r in sw["records"]] == ["sizable", "not sizable"]
    assert sw["monte_carlo_sized"] == [True, False]
    assert sw["records"][0]["fit_sized_share"] >= 0.8 > 0.5 > sw["records"][1]["fit_sized_share"]
    assert 16.0 < sw["bound_cpa_m"] < 24.0 and sw["monte_carlo_cpa_m"] == pytest.approx(16.0)
    with open(tmp_path / "cpa_sweep.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == cli.SWEEP_COLUMNS and len(rows) == 2
    for r in rows:
        b = bd.shape_bound(Target(), Pass(start=(-40.0, 5.0, -5.0)).with_closest_approach(float(r["closest_approach_m"])))
        assert float(r["bound_second_moment_m"]) == pytest.approx(b.spread_main_scale_m, rel=1e-5)
        assert float(r["bound_span_m"]) == pytest.approx(b.main_scale_m, rel=1e-5)
        assert r["sizable"] == str(b.sizable).lower()
    assert (tmp_path / "cpa_sweep.png").stat().st_size > 10_000
    assert "must come within" in cli.sweep_answer(sw)


@pytest.mark.parametrize("args, says", [
    (["--offset", "500"], "between -100 and 100 m"),
    (["--above", "x"], "must be a number"),
    (["--noise", "0"], "between 1e-05 and 10 nT/m"),
    (["--speed", "0.1"], "between 0.5 and 20 m/s"),
    (["--rate", "100"], "between 0.1 and 50 Hz"),
    (["--rate", "20", "--speed", "0.5"], "makes 3201 samples"),
    (["--offset", "0", "--above", "0.5"], "m from the target's nearest cell; keep it at least 1 m away"),
    (["--lag", "5", "--rate", "0.5"], "the largest lag accepted is 4"),
    (["--speed", "20", "--rate", "0.25"], "makes 2 samples over the 80 m pass; the 4-dipole model has 15 unknowns"),
    (["--speed", "20", "--rate", "0.1"], "makes 1 sample over the 80 m pass"),
    (["--cpa-sweep", "5:40"], "must be LO:HI:N"),
    (["--cpa-sweep", "40:5:3"], "0 < LO < HI"),
    (["--cpa-sweep", "5:40:1"], "N must be 2 to 40"),
    (["--cpa-sweep", "0.5:40:3"], "start the sweep farther"),
    (["--size-to", "0.1"], "--size-to needs --cpa-sweep"),
])
def test_pass_options_are_refused_with_one_clear_message(tmp_path, args, says):
    argv = ["--case", "seed003-fig4", *args, "--out", str(tmp_path / "o")]
    p = subprocess.run([sys.executable, "-m", "core.shape", *argv], cwd=ROOT, capture_output=True,
                       text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin"})
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("python -m core.shape: error:"), p.stderr
    assert says in lines[0], lines[0]
    assert not (tmp_path / "o" / "summary.json").exists()


def test_speed_and_rate_set_the_samples():
    from core.shape.cases import case_rows

    row = case_rows("seed003-fig4")[1][0]
    r = cli.geometry(row, speed=2.0, rate=10.0, noise=0.02)
    assert r.track.samples == 401 and r.track.rate == 10.0 and r.track.velocity == (2.0, 0.0, 0.0)
    assert r.noise_g == r.noise_b == 0.02
    assert r.track.positions[-1, 0] == pytest.approx(40.0)
    assert cli.geometry(row) == row  # no option: the case's own pass


def test_a_verdict_that_is_not_the_targets_kind_gets_a_caution():
    """Issue 40, defect 14: the command printed "plane" for a line with no caution."""
    row = {"truth": {"target": {"kind": "line"}},
           "filters": {"euler": {"centroid_error_m": 0.4},
                       "ukf": {"kind": "line", "kind_share": {"line": 1.0}},
                       "nhukf": {"kind": "plane", "kind_share": {"plane": 0.6, "line": 0.4}},
                       "fit": {"kind": "tie", "kind_share": {"plane": 0.5, "line": 0.5}}}}
    got = cli.cautions(row)
    assert got == ["CAUTION: nhukf reads a plane (60 % of runs) but the target is a line: its main "
                   "scale and axis are not the target's",
                   "CAUTION: fit reads a tie (50 % of runs) but the target is a line: its main "
                   "scale and axis are not the target's"]
    row["filters"]["nhukf"]["kind"] = row["filters"]["fit"]["kind"] = "line"
    assert cli.cautions(row) == []


@pytest.mark.parametrize("lag", [0, 4])
def test_a_short_pass_runs_and_counts_its_last_sample(tmp_path, lag):
    """Issue 46: a pass of ≤ 10 samples (SETTLE) crashed the command with KeyError: 'misfit'
    (the summary took the filters' 9-sample tracks for the fit's one estimate). 9 samples (5 m/s,
    0.5 Hz) with lag 0 and the largest lag 4: the command ends with status 0, the summary counts
    the filters' peak error and NEES from the last sample (settle_samples 8), and the fit's entry
    has its own fields."""
    p = subprocess.run([sys.executable, "-m", "core.shape", "--case", "seed003-fig4", "--speed", "5",
                        "--rate", "0.5", "--lag", str(lag), "--out", str(tmp_path)], cwd=ROOT,
                       capture_output=True, text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin"})
    assert p.returncode == 0, p.stderr
    data = json.loads((tmp_path / "summary.json").read_text())
    row = data["rows"][0]
    assert row["truth"]["pass"]["samples"] == 9 and data["lag"] == lag and row["settle_samples"] == 8
    f = data["filters"]
    for name in ("euler", "ukf", "nhukf"):  # one sample counted: its peak is its final error
        assert f[name]["peak_error_m"] == f[name]["centroid_error_m"], (name, f[name])
    assert {"misfit", "converged_share", "nees_band"} <= set(f["fit"]) and "peak_error_m" not in f["fit"]


def test_the_lag_help_states_the_real_default():
    """Issue 46: --lag's help said the figures default to lag 0; every case runs seed 003's window
    (cases.PAPER_LAG) and the figures add the one-sample update beside it."""
    from core.shape.cases import CASES, PAPER_LAG

    text = " ".join(cli._parser().format_help().split())
    assert f"seed 003's window of lag {PAPER_LAG} for every case" in text
    assert "figures 0" not in text
    assert {r.lag for _, rows in CASES.values() for r in rows if not r.comparison} == {PAPER_LAG}


def test_huge_noise_prints_no_converged_fit(tmp_path):
    """Issue 46: --noise 10 printed a fit centroid of 1.6e29 m with converged_share 1.0 (its
    dipoles ran off to where the model's field is nil, the best fit of pure noise). Now the
    fits end implausible (a dipole farther from the centroid than the track is), are counted
    not converged, left out of the medians (null) and the command says so."""
    p = subprocess.run([sys.executable, "-m", "core.shape", "--case", "seed003-fig4", "--noise", "10",
                        "--lag", "5", "--runs", "2", "--out", str(tmp_path)], cwd=ROOT,
                       capture_output=True, text=True, env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin"})
    assert p.returncode == 0, p.stderr
    fit = json.loads((tmp_path / "summary.json").read_text())["filters"]["fit"]
    assert fit["converged_share"] == 0.0 and fit["plausible_share"] == 0.0
    assert fit["centroid_error_m"] is None and fit["main_scale_m"] is None and fit["kind"] == "none"
    assert "fit: no pass converged to a plausible answer" in p.stdout
    assert "WARNING: the fit did not converge to a plausible answer in 2 of 2 passes" in p.stdout
    assert "CAUTION: fit" not in p.stdout


def test_the_sweeps_far_row_prints_no_runaway_fit(tmp_path):
    """Issue 46: the 50 m row of --cpa-sweep's CSV had a fit error of 1e22 m. The fit's columns
    are now medians over its converged (plausible) passes, with its converged share beside them:
    what is left is a size the pass could have seen (< 200 m, four times the closest approach;
    measured ≤ 172 m over 6 passes at 50 m before the change dropped the runaways: the 1e22 m
    came from a fit whose dipoles had left), or NaN when no pass converged."""
    cli.cpa_sweep("seed003-fig4", 40.0, 50.0, 2, runs=3, seed=0, out=str(tmp_path), plots=False)
    with open(tmp_path / "cpa_sweep.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        assert 0.0 <= float(r["fit_converged_share"]) <= 1.0 and float(r["fit_sized_share"]) == 0.0
        for q in ("span_error_m", "second_moment_error_m"):
            v = float(r[f"fit_{q}"])
            assert np.isnan(v) or v < 200.0, (r["closest_approach_m"], q, v)
        assert r["verdict"] == "not sizable"
