"""Sensor-layout design (core.observability.crlb, .layouts, .design) and the sweep CLI (core.sweep)."""

import csv
import subprocess
import sys

import numpy as np
import pytest

import core
from tests.conftest import PAPER_STATE, random_states

DUAL15 = core.dual_station(100, 15)
REGION = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 15)


def _stacked_field(states, stations, steps, T=1.0):
    """All components of all stations at ``steps`` instants, in Γ's row order (time-major,
    station-major, component): (P, 3·S·N) in V/m."""
    out = []
    for i in range(steps):
        moved = states.copy()
        moved[:, :2] += i * T * states[:, 3:5]  # X_{k+i} = Φ^i X_k
        out.append(core.dipole_field(moved, stations).reshape(len(states), -1))
    return np.concatenate(out, axis=1)


def test_crlb_matches_monte_carlo_least_squares():
    # 500 noisy experiments, each solved by Gauss–Newton from the truth; the Jacobian of the
    # stacked measurements w.r.t. X_k is exactly the all-rows Γ. Small noise keeps the problem
    # in its linear regime, where the least-squares estimate attains the CRLB.
    rng = np.random.default_rng(6)
    trials, steps, noise = 500, 3, 1e-8
    truth = PAPER_STATE
    clean = _stacked_field(truth[None], DUAL15, steps)[0]
    meas = clean + noise * rng.standard_normal((trials, clean.size))
    est = np.tile(truth, (trials, 1))
    for _ in range(4):
        g = core.gamma(est, DUAL15, steps=steps)  # (P, 18, 7)
        norms = np.linalg.norm(g, axis=1, keepdims=True)
        q, r = np.linalg.qr(g / norms)  # column-scaled for conditioning
        resid = meas - _stacked_field(est, DUAL15, steps)
        step = np.linalg.solve(r, np.einsum("prc,pr->pc", q, resid)[..., None])[..., 0]
        est = est + step / norms[:, 0, :]
    assert np.max(np.abs(step / norms[:, 0, :])) < 1e-6 * np.max(np.abs(est))  # converged
    e = core.horizontal_error_ellipse(truth, DUAL15, noise=noise, steps=steps)
    std = core.fisher_measures(truth, DUAL15, noise=noise, steps=steps).std
    sample = est.std(axis=0, ddof=1)
    speed = np.hypot(est[:, 3], est[:, 4])
    # Relative standard error of a sample std of n normal draws: 1/sqrt(2(n−1)) ≈ 3.2 %;
    # allow 4 standard errors (two-sided p ≈ 6e-5 per comparison).
    tol = 4 / np.sqrt(2 * (trials - 1))
    np.testing.assert_allclose(sample, std, rtol=tol)
    np.testing.assert_allclose(speed.std(ddof=1), e.sigma_speed, rtol=tol)
    np.testing.assert_allclose(sample[2], e.sigma_z, rtol=tol)
    # The sample (x, y) ellipse: its semi-axes from the sample covariance.
    lam = np.linalg.eigvalsh(np.cov(est[:, :2].T))
    np.testing.assert_allclose(np.sqrt(lam[::-1]), [e.semi_major, e.semi_minor], rtol=tol)


def assert_cov_close(a, b):
    """Covariances agree entry by entry in units of sqrt(b_ii b_jj) (scale-free: the states'
    units differ by orders of magnitude). Measured: 1.3e-11 for F with condition numbers up to
    3e9, whose dense inverse may err by up to eps·cond ≈ 7e-7; 1e-8 leaves 700× margin."""
    s = np.sqrt(np.diagonal(b, axis1=-2, axis2=-1))
    np.testing.assert_allclose(a / (s[..., :, None] * s[..., None, :]),
                               b / (s[..., :, None] * s[..., None, :]), atol=1e-8)


def test_covariance_matches_dense_inverse_and_core_std(rng):
    states = random_states(rng, 20, DUAL15)
    cov, ok = core.crlb_covariance(states, DUAL15, noise=3e-8, steps=4)
    assert ok.all()
    dense = np.linalg.inv(core.fisher_information(states, DUAL15, noise=3e-8, steps=4))
    assert_cov_close(cov, dense)
    std = core.fisher_measures(states, DUAL15, noise=3e-8, steps=4).std
    np.testing.assert_allclose(np.sqrt(np.diagonal(cov, axis1=1, axis2=2)), std, rtol=1e-8)
    # Known states get zero rows and columns; the rest is the reduced problem's covariance.
    cov_k, _ = core.crlb_covariance(states, DUAL15, noise=3e-8, steps=4, known=("Ph", "Pv"))
    assert np.all(cov_k[:, 5:, :] == 0) and np.all(cov_k[:, :, 5:] == 0)
    red = np.linalg.inv(core.fisher_information(states, DUAL15, noise=3e-8, steps=4,
                                                known=("Ph", "Pv")))
    assert_cov_close(cov_k[:, :5, :5], red)


def test_ellipse_agrees_with_eigendecomposition(rng):
    states = random_states(rng, 40, DUAL15)
    cov, _ = core.crlb_covariance(states, DUAL15)
    e = core.horizontal_error_ellipse(states, DUAL15)
    lam, vec = np.linalg.eigh(cov[:, :2, :2])  # ascending
    np.testing.assert_allclose(e.semi_major, np.sqrt(lam[:, 1]), rtol=1e-10)
    np.testing.assert_allclose(e.semi_minor, np.sqrt(lam[:, 0]), rtol=1e-8)
    major = vec[:, :, 1]
    angle = np.degrees(np.arctan2(major[:, 1], major[:, 0]))
    diff = (e.orientation - angle + 90.0) % 180.0 - 90.0  # an axis, not a direction
    np.testing.assert_allclose(diff, 0.0, atol=1e-8)
    assert np.all((e.orientation > -90) & (e.orientation <= 90))
    np.testing.assert_allclose(e.position, np.sqrt(np.trace(cov[:, :3, :3], axis1=1, axis2=2)),
                               rtol=1e-12)


@pytest.mark.parametrize("stations,known", [
    (core.single_station(100), ()),
    (core.single_station(100), ("Ph", "Pv")),
    (DUAL15, ()),
    (core.station_layout("triangle", 3, d=20, h=100), ()),
])
def test_crlb_infinite_exactly_where_rank_test_says_unobservable(rng, stations, known):
    states = random_states(rng, 40, stations)
    n = 7 - len(known)
    rank = core.observable_rank(states, stations, steps=core.DEFAULT_STEPS, known=known)
    e = core.horizontal_error_ellipse(states, stations, known=known)
    cov, ok = core.crlb_covariance(states, stations, known=known)
    unobs = rank < n
    np.testing.assert_array_equal(~ok, unobs)
    for arr in (e.semi_major, e.semi_minor, e.sigma_z, e.sigma_speed, e.position):
        np.testing.assert_array_equal(np.isinf(arr), unobs)
        assert np.all(np.isfinite(arr[~unobs]))
    np.testing.assert_array_equal(np.isnan(e.orientation), unobs)
    assert np.all(np.isinf(np.diagonal(cov[unobs], axis1=1, axis2=2)[:, :n]))


def test_crlb_maps_match_pointwise_and_mask_stations():
    plane = core.Plane("xz", (-60, 60), (60, 140), 0.0, 9)  # passes through both stations
    e = core.crlb_maps(plane, DUAL15, velocity=(2, 2), moments=(100, 20))
    states = plane.states((2, 2), (100, 20))
    on = np.min(np.linalg.norm(states[..., None, :3] - DUAL15, axis=-1), axis=-1) < 1e-6
    assert on.sum() == 2 and np.isnan(e.semi_major[on]).all() and not e.observable[on].any()
    pts = core.horizontal_error_ellipse(states[~on], DUAL15)
    np.testing.assert_allclose(e.sigma_speed[~on], pts.sigma_speed, rtol=1e-12)
    np.testing.assert_allclose(e.position[~on],
                               core.evaluate_map(plane, DUAL15, velocity=(2, 2), moments=(100, 20),
                                                 measure="crlb_position").value[~on], rtol=1e-8)
    single = core.crlb_maps(plane, core.single_station(100), velocity=(2, 2), moments=(100, 20))
    on1 = np.linalg.norm(states[..., :3] - [0, 0, 100], axis=-1) < 1e-6
    assert np.all(np.isinf(single.semi_major[~on1])) and np.isnan(single.semi_major[on1]).all()


def test_layouts():
    np.testing.assert_array_equal(core.station_layout("line", 2, d=15, h=100), DUAL15)
    tri = core.station_layout("triangle", 3, d=20, h=90)
    sides = np.linalg.norm(tri[[0, 1, 2]] - tri[[1, 2, 0]], axis=1)
    np.testing.assert_allclose(sides, 20.0, rtol=1e-12)
    sq = core.station_layout("square", 4, d=7, h=90)
    np.testing.assert_allclose(np.sort(np.linalg.norm(sq - sq[0], axis=1)),
                               [0, 7, 7, 7 * np.sqrt(2)], rtol=1e-12)
    for kind in ("line", "triangle", "square"):
        for n in range(1, core.MAX_STATIONS + 1):
            st = core.station_layout(kind, n, d=10, h=100)
            assert st.shape == (n, 3) and np.all(st[0] == [0, 0, 100]) and np.all(st[:, 2] == 100)
            gaps = np.linalg.norm(st[:, None] - st[None], axis=-1) + 1e9 * np.eye(n)
            assert np.all(gaps >= 10 - 1e-9)  # lattice: no two stations closer than d
    free = core.station_layout("free", None, positions=[[0, 0], [5, 5]], h=80)
    np.testing.assert_array_equal(free, [[0, 0, 80], [5, 5, 80]])


@pytest.mark.parametrize("call,match", [
    (lambda: core.station_layout("hexagon", 3), "layout kind"),
    (lambda: core.station_layout("line", 9), "n_stations"),
    (lambda: core.station_layout("line", 2, d=0), "d must be"),
    (lambda: core.station_layout("free", 2), "positions"),
    (lambda: core.station_layout("free", 3, positions=[[0, 0], [1, 1]]), "does not match"),
    (lambda: core.layout_criterion(DUAL15, REGION, criterion="best"), "criterion"),
    (lambda: core.layout_criterion(DUAL15, REGION, criterion="area_crlb", threshold=-1),
     "threshold"),
    (lambda: core.layout_criterion(DUAL15, "region"), "region must be a core.Plane"),
    (lambda: core.layout_criterion(DUAL15, REGION, velocity=(0, 0)), "speed"),
    (lambda: core.spacing_curve([10, -5], core.LayoutProblem(REGION)), "d_values"),
    (lambda: core.best_spacing(core.LayoutProblem(REGION), d_range=(50, 10)), "d_range"),
    (lambda: core.optimise_layout("free", 2, core.LayoutProblem(REGION), x0=[[0, 0]]), "x0"),
    (lambda: core.best_spacing(REGION), "must be a core.LayoutProblem"),
    (lambda: core.horizontal_error_ellipse(PAPER_STATE, DUAL15, noise=0), "noise"),
    (lambda: core.crlb_maps(REGION, DUAL15, velocity=(2, 2, 0), moments=(1, 1)), "velocity"),
])
def test_bad_input_raises(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_adding_a_station_never_lowers_d_optimal(rng):
    # F grows by a positive semi-definite term with each station, so det F cannot fall.
    for n in range(1, 5):
        fewer = core.station_layout("line", n, d=25, h=100)
        more = core.station_layout("line", n + 1, d=25, h=100)
        states = random_states(rng, 30, more)
        a = core.fisher_measures(states, fewer).d_optimal
        b = core.fisher_measures(states, more).d_optimal
        assert np.all(b >= a - 1e-9)
        if n >= 2:
            ca = core.layout_criterion(fewer, REGION, criterion="worst_dopt").value
            cb = core.layout_criterion(more, REGION, criterion="worst_dopt").value
            assert cb >= ca - 1e-9


def test_unobservable_points_get_the_eta_floor():
    # One station: nothing observable, the criterion is the mean of the per-point floors,
    # strictly below the dual layout's mean (which has no floored points here).
    one = core.layout_criterion(core.single_station(100), REGION)
    two = core.layout_criterion(DUAL15, REGION)
    assert one.observable_fraction == 0.0 and two.observable_fraction == 1.0
    assert np.isfinite(one.value) and one.value < two.value
    area = core.layout_criterion(core.single_station(100), REGION, criterion="area_crlb",
                                 threshold=1e9)
    assert area.value == 0.0


@pytest.mark.parametrize("criterion", ["mean_dopt", "worst_dopt"])
def test_best_spacing_is_an_optimum(criterion):
    problem = core.LayoutProblem(REGION, criterion=criterion)
    r = core.best_spacing(problem, d_range=(5, 400), n_curve=9, xatol=0.01)
    assert not r.at_bound and r.value >= r.curve.max()
    step = r.d_values[1] - r.d_values[0]
    fine = np.linspace(r.d - step, r.d + step, 41)
    values = core.spacing_curve(fine, problem)
    # Brent stops within xatol of the peak: the criterion, flat there, may gain at most a
    # curvature · xatol² sliver (measured < 1e-7); anything larger would be a missed optimum.
    assert np.all(values <= r.value + 1e-6)
    # …and it is a peak, not a plateau edge: the fine grid's ends are clearly lower.
    assert max(values[0], values[-1]) < r.value - 1e-4


def test_optimise_layout_scaled_and_free():
    small = core.Plane("xy", (-200, 200), (-200, 200), 120.0, 9)
    sq = core.optimise_layout("square", 4, core.LayoutProblem(small), d_range=(5, 300), n_curve=7)
    lattice = core.station_layout("square", 4, d=sq.d, h=100)
    np.testing.assert_allclose(sq.stations, lattice - [[sq.d / 2, sq.d / 2, 0]])  # centred
    free = core.optimise_layout("free", 3, core.LayoutProblem(small), d_range=(5, 300), n_curve=7, maxfev=150)
    assert free.stations.shape == (3, 3) and np.all(free.stations[:, 2] == 100)
    assert np.all(np.abs(free.stations[:, :2]) <= 200)
    square_start = core.optimise_layout("square", 3, core.LayoutProblem(small), d_range=(5, 300), n_curve=7)
    assert free.value >= square_start.value - 1e-12  # never worse than its start
    np.testing.assert_allclose(free.value, core.layout_criterion(free.stations, small).value)


def test_sweep_cli_writes_csv_and_png(tmp_path):
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "core.sweep", "--x", "d=5:45:3", "--y", "z=110,200",
           "--measure", "d_optimal", "--out", str(out), "--workers", "2", "--no-progress"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120,
                          check=False)
    assert done.returncode == 0, done.stderr
    with open(out / "sweep.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["d", "z", "d_optimal"] and len(rows) == 1 + 3 * 2
    table = np.array(rows[1:], dtype=float)
    np.testing.assert_allclose(sorted(set(table[:, 0])), [5, 25, 45])
    np.testing.assert_allclose(sorted(set(table[:, 1])), [110, 200])
    for d, z, value in table:
        state = PAPER_STATE.copy()
        state[2] = z
        expect = core.fisher_measures(state, core.dual_station(100, d)).d_optimal
        np.testing.assert_allclose(value, expect, rtol=1e-12)
    assert (out / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = subprocess.run([sys.executable, "-m", "core.sweep", "--x", "d=0:5:2", "--y", "z=1,2",
                          "--out", str(out)], capture_output=True, text=True, timeout=60, check=False)
    assert bad.returncode == 2 and "d must be > 0" in bad.stderr


# Issue 25: a depth above the sea surface (z, h < 0) was swept without a word (cells computed
# for a target in the air); one below the seabed of --sea-depth ended in a traceback from a
# worker, unless it was the first cell. Both are refused, like every bad argument, with one
# error line (after argparse's usage) and exit status 2, before anything is computed or written.
@pytest.mark.parametrize("args,message", [
    (["--y", "z=-100:400:4"], "parameter z (target depth) = -100 m is above the sea surface"),
    (["--y", "h=-1,50"], "parameter h (station depth) = -1 m is above the sea surface"),
    (["--y", "x=1,2", "--set", "z=-5"], "parameter z (target depth) = -5 m is above the sea surface"),
    (["--y", "z=100:400:4", "--sea-depth", "200"],
     "parameter z (target depth) = 400 m is below the seabed: with --sea-depth 200"),
])
def test_sweep_cli_refuses_depths_outside_the_sea(tmp_path, capsys, args, message):
    from core.cli import sweep

    out = tmp_path / "sweep"
    with pytest.raises(SystemExit) as exc:
        sweep.main(["--x", "d=5:45:3", *args, "--out", str(out), "--workers", "1", "--no-progress"])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.splitlines()[-1].startswith(f"python -m core.sweep: error: {message}"), err
    assert "Traceback" not in err and not out.exists()


# Issue 16, defect 7: scaled layouts centred on the region, bounds from the region, bounds reported.
APP_REGION = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 31)  # the app's Layout design grid
APP_PROBLEM = core.LayoutProblem(APP_REGION)


def _centred(kind, n, d, centre, h=100.0):
    st = core.station_layout(kind, n, d=d, h=h)
    st[:, :2] += np.asarray(centre) - st[:, :2].mean(axis=0)
    return st


@pytest.mark.parametrize("region,centre", [
    (APP_REGION, (0.0, 0.0)),
    (core.Plane("xy", (100, 700), (-200, 400), 120.0, 31), (400.0, 100.0)),
])
def test_square_of_four_is_centred_on_the_region_and_not_capped(region, centre):
    r = core.optimise_layout("square", 4, core.LayoutProblem(region))
    np.testing.assert_allclose(r.stations[:, :2].mean(axis=0), centre, atol=1e-9)
    np.testing.assert_allclose(r.stations, _centred("square", 4, r.d, centre))
    # the old optimiser stopped at its 200 m cap (199.98 m, a corner at the origin)
    assert 250.0 < r.d < 600.0 and r.at_bound == ()
    np.testing.assert_allclose(r.value, core.layout_criterion(r.stations, region).value)
    # an interior optimum: 5 m either way is no better (Brent's xatol is 0.05 m)
    for d in (r.d - 5.0, r.d + 5.0):
        assert core.layout_criterion(_centred("square", 4, d, centre), region).value < r.value
    # and it beats the old answer, the capped corner-anchored square
    old = core.layout_criterion(core.station_layout("square", 4, d=199.98, h=100), region).value
    assert r.value > old + 0.1


def test_at_bound_names_the_spacing_bound_that_is_hit():
    r = core.optimise_layout("square", 4, APP_PROBLEM, d_range=(2.0, 200.0))
    assert r.at_bound == ("d_max",) and abs(r.d - 200.0) < 0.1
    # the bound binds: a wider square does better
    wider = core.layout_criterion(_centred("square", 4, 220.0, (0, 0)), APP_REGION).value
    assert wider > r.value
    lo = core.optimise_layout("line", 2, APP_PROBLEM, d_range=(300.0, 500.0))
    assert lo.at_bound == ("d_min",) and abs(lo.d - 300.0) < 0.1


def test_at_bound_names_the_box_sides_a_free_station_touches():
    box = ((-20.0, 20.0), (-20.0, 20.0))
    r = core.optimise_layout("free", 2, APP_PROBLEM, bounds=box, maxfev=150)
    assert len(r.at_bound) >= 1 and set(r.at_bound) <= {"x_min", "x_max", "y_min", "y_max"}
    sides = {"x_min": (0, -20.0), "x_max": (0, 20.0), "y_min": (1, -20.0), "y_max": (1, 20.0)}
    for name in r.at_bound:
        axis, edge = sides[name]
        assert np.min(np.abs(r.stations[:, axis] - edge)) <= 40.0 * 1e-3
    # the box binds: the same optimiser in a wider box finds a better layout
    wide = core.optimise_layout("free", 2, APP_PROBLEM, bounds=((-60, 60), (-60, 60)), maxfev=150)
    assert wide.value > r.value
    interior = core.optimise_layout("free", 2, APP_PROBLEM, maxfev=150)
    assert interior.at_bound == ()


def test_one_station_layout_reports_no_spacing_bound():
    r = core.optimise_layout("line", 1, APP_PROBLEM, n_curve=3)
    assert r.at_bound == () and r.stations.tolist() == [[0.0, 0.0, 100.0]]  # centred


def test_layout_searches_take_only_the_problem():
    """Issue 47 item 5: a LayoutProblem is the one way in; the old keyword forms are gone."""
    region = core.Plane("xy", (-60, 60), (-60, 60), 15.0, 7)
    problem = core.LayoutProblem(region, h=0.0, moments=(1e3, -2e3, 5e2), criterion="worst_dopt",
                                 steps=2, sensor=core.Sensor("BG"))
    r = core.optimise_layout("line", 2, problem, d_range=(2, 40), n_curve=4)
    np.testing.assert_allclose(r.value, core.layout_criterion(
        r.stations, region, moments=(1e3, -2e3, 5e2), criterion="worst_dopt", steps=2,
        sensor=core.Sensor("BG")).value, rtol=0, atol=0)
    for call in (lambda: core.optimise_layout("line", 2, problem, steps=5),
                 lambda: core.best_spacing(problem, h=5.0),
                 lambda: core.spacing_curve([5.0], problem, sensor="B")):
        with pytest.raises(TypeError, match="unexpected keyword"):
            call()
