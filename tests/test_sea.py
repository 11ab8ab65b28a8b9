"""The layered sea (air / seawater / seabed, spec §7): core.Sea and the image-series field.

References, independent of core.model.sea:
- empymod (a Hankel-transform layered-earth code) at DC;
- closed forms: η = 0 (only the surface image: a half-space) and D → ∞;
- a brute-force image sum written here in numpy (thousands of groups, no tail), which also runs
  in complex arithmetic for complex-step derivatives.
"""

import empymod
import numpy as np
import pytest

import core
from core.model.sea import Sea, image_counts

SIGMA = 4.0


# --------------------------------------------------------------------------------------------
# independent references
# --------------------------------------------------------------------------------------------

def free_field(src, p, rec, sigma=SIGMA):
    """Whole-space current-dipole field at rec of dipoles p at src, summed over the leading
    axis of src/p: E = (3 (p·R) R / R⁵ − p / R³) / (4πσ), R = rec − src. Complex-safe."""
    r = rec[None, :] - src
    d2 = np.sum(r * r, axis=-1)
    pr = np.sum(p * r, axis=-1)
    return np.sum((3 * pr[:, None] * r / d2[:, None] ** 2.5 - p / d2[:, None] ** 1.5), axis=0) / (
        4 * np.pi * sigma)


def brute_images(state, station, depth, seabed_sigma, groups, sigma=SIGMA):
    """The image series of docs/sea.md summed term by term, |m| ≤ groups, smallest first."""
    x, y, z, vx, vy, ph, pv = state
    speed = np.sqrt(vx * vx + vy * vy)  # complex-safe (no abs)
    p = np.array([ph * vx / speed, ph * vy / speed, pv])
    eta = (sigma - seabed_sigma) / (sigma + seabed_sigma)
    m = np.arange(-groups, groups + 1)
    m = m[np.argsort(-np.abs(m), kind="stable")]
    total = 0
    for eps in (1.0, -1.0):
        zs = eps * z + 2.0 * m * depth
        src = np.stack([x + 0 * zs, y + 0 * zs, zs], axis=-1)
        w = (eta ** np.abs(m))[:, None]
        pm = np.broadcast_to(np.array([p[0], p[1], eps * p[2]]), src.shape) * w
        total = total + free_field(src, pm, np.asarray(station, dtype=float), sigma)
    return total


def empymod_tensor(src, rec, depth, seabed_sigma, sigma=SIGMA):
    """3 × 3 DC Green tensor G[i, j] = E_i at rec of a unit dipole along j at src."""
    res = [2e14, 1 / sigma, 2e14 if seabed_sigma == 0 else 1 / seabed_sigma]
    return np.array([[empymod.dipole(src=list(src), rec=list(rec), depth=[0, depth], res=res,
                                     freqtime=1e-20, ab=10 * (i + 1) + (j + 1), verb=0).real
                      for j in range(3)] for i in range(3)])


def core_tensor(src, rec, sea, sigma=SIGMA):
    """The same tensor from core: heading along x, along y (Ph = 1), and Pv = 1."""
    states = np.array([[*src, 1, 0, 1, 0], [*src, 0, 1, 1, 0], [*src, 1, 0, 0, 1]], dtype=float)
    return core.dipole_field(states, [rec], sigma=sigma, sea=sea)[:, 0, :].T


def rel(a, b):
    return np.linalg.norm(np.asarray(a) - b) / np.linalg.norm(b)


# --------------------------------------------------------------------------------------------
# the field
# --------------------------------------------------------------------------------------------

def random_geometry(rng, n):
    """n (depth, σb, source, receiver): depths 5–500 m (log-uniform), σb 0.01–20 S/m
    (log-uniform), source anywhere in the column, receiver anywhere in it or on the seabed
    (every third), horizontal range 0.1–30 D."""
    out = []
    for k in range(n):
        depth = 10 ** rng.uniform(np.log10(5), np.log10(500))
        sb = 10 ** rng.uniform(-2, np.log10(20))
        src = np.array([*rng.uniform(-20, 20, 2), rng.uniform(0, depth)])
        rho, ang = depth * 10 ** rng.uniform(-1, 1.5), rng.uniform(0, 2 * np.pi)
        rec = np.array([src[0] + rho * np.cos(ang), src[1] + rho * np.sin(ang),
                        depth if k % 3 == 0 else rng.uniform(0, depth)])
        out.append((depth, sb, src, rec))
    return out


def test_field_matches_empymod(rng):
    # Relative to the norm of the 3 × 3 dipole tensor: a single column can cancel strongly
    # (a vertical dipole near the insulating surface, far away, is ~40× weaker than its images),
    # and empymod's DC value carries ~5e-6 of the uncancelled size (spec §7). Our own
    # truncation is checked per vector in test_truncation_tolerance.
    worst = 0.0
    for depth, sb, src, rec in random_geometry(rng, 24):
        err = rel(core_tensor(src, rec, Sea(depth, sb)), empymod_tensor(src, rec, depth, sb))
        worst = max(worst, err)
    assert worst <= 1e-5


def test_insulating_seabed_matches_empymod():
    # σb = 0 (η = 1): the slowest series, closed by its tail.
    for rho in (5.0, 60.0, 400.0):
        src, rec = np.array([0.0, 0.0, 3.0]), np.array([rho, 0.3 * rho, 8.4])
        assert rel(core_tensor(src, rec, Sea(8.4, 0.0)), empymod_tensor(src, rec, 8.4, 0.0)) <= 1e-5


@pytest.mark.parametrize("sb, rho_over_d", [(0.01, 30.0), (0.01, 3.0), (0.4, 30.0), (1.0, 2.0),
                                            (4.0, 5.0), (20.0, 10.0), (200.0, 3.0)])
def test_truncation_tolerance(sb, rho_over_d):
    # Every vector (each moment separately) within the documented 1e-6 of the brute-force sum
    # (η from 0.995 to −0.96, ranges to 30 D). 60000 groups: the omitted rest is < 1e-9.
    depth = 20.0
    for state in ([rho_over_d * depth, 0.2 * depth, 7.0, 1.0, 0.3, 1.0, 0.0],
                  [rho_over_d * depth, 0.2 * depth, 7.0, 1.0, 0.3, 0.0, 1.0]):
        station = [0.0, 0.0, depth]
        ref = brute_images(np.array(state), station, depth, sb, 60000)
        got = core.dipole_field(state, [station], sea=Sea(depth, sb))[0]
        assert rel(got, ref) <= 1e-6


def test_half_space_closed_form(rng):
    # η = 0 (σb = σ): the source and its surface image only.
    for _ in range(10):
        depth = rng.uniform(5, 500)
        src = np.r_[rng.uniform(-50, 50, 2), rng.uniform(0, depth)]
        rec = np.r_[rng.uniform(-300, 300, 2), rng.uniform(0, depth)]
        p = np.array([0.6, 0.8, 0.5]) * 100
        half = free_field(np.array([src, src * [1, 1, -1]]), np.array([p, p * [1, 1, -1]]), rec)
        state = [*src, 0.6, 0.8, 100.0, 50.0]
        got = core.dipole_field(state, [rec], sea=Sea(depth, SIGMA))[0]
        assert rel(got, half) <= 1e-13
        assert image_counts(state, [rec], Sea(depth, SIGMA))[0] == 2


def test_deep_sea_is_the_half_space():
    # D → ∞: the seabed images recede and the field tends to the half-space's, the difference
    # falling as D⁻³ (the nearest seabed image, a dipole at ~2D).
    src, rec = np.array([0.0, 0.0, 120.0]), np.array([200.0, 100.0, 100.0])
    p = np.array([100 / np.sqrt(2), 100 / np.sqrt(2), 20.0])
    half = free_field(np.array([src, src * [1, 1, -1]]), np.array([p, p * [1, 1, -1]]), rec)
    errors = [rel(core.dipole_field([*src, 1, 1, 100.0, 20.0], [rec], sea=Sea(d, 0.1))[0], half)
              for d in (1e3, 1e4, 1e5)]
    assert errors[2] < 1e-8
    np.testing.assert_allclose([errors[0] / errors[1], errors[1] / errors[2]], 1e3, rtol=0.05)


# --------------------------------------------------------------------------------------------
# Jacobians
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("sb, groups", [(1.0, 200), (0.1, 2000), (10.0, 200)])
def test_jacobian_against_complex_step(sb, groups):
    # Complex-step derivatives of the brute-force sum (independent of core's kernel and tail)
    # against the chain rule through the images, with a tight tolerance so that both are the
    # converged series.
    depth, h = 60.0, 1e-30
    sea = Sea(depth, sb, tol=1e-12)
    stations = np.array([[0.0, 0.0, depth], [15.0, 5.0, 20.0]])
    for state in ([30.0, 40.0, 35.0, 2.0, 1.5, 100.0, 20.0], [-150.0, 80.0, 2.0, -1.0, 2.5, 40.0, -70.0]):
        jac = core.field_jacobian(state, stations, sea=sea)
        for s, st in enumerate(stations):
            cs = np.empty((3, 7))
            for j in range(7):
                x = np.array(state, dtype=complex)
                x[j] += 1j * h
                cs[:, j] = brute_images(x, st, depth, sb, groups).imag / h
            scale = np.linalg.norm(cs, axis=1, keepdims=True)  # per component, all states
            assert np.max(np.abs(jac[s] - cs) / scale) <= 1e-8


def test_jacobian_is_the_derivative_of_the_truncated_field():
    # In the slowly converging case the default tolerance truncates after ~50 groups and closes
    # the rest with the tail: its Jacobian must still be the exact derivative of that field
    # (image positions and tail nodes depend only on the group count, locally constant).
    sea = Sea(8.4, 0.01)
    state = np.array([150.0, -60.0, 0.2, 2.0, 1.0, 100.0, 20.0])
    station = [[0.0, 0.0, 8.4]]
    jac = core.field_jacobian(state, station, sea=sea)[0]
    steps = np.array([1e-3, 1e-3, 1e-4, 1e-4, 1e-4, 1e-2, 1e-2])
    fd = np.empty((3, 7))
    for j in range(7):  # 4th-order central differences
        e = np.eye(7)[j] * steps[j]
        f = [core.dipole_field(state + k * e, station, sea=sea)[0] for k in (-2, -1, 1, 2)]
        fd[:, j] = (f[0] - 8 * f[1] + 8 * f[2] - f[3]) / (12 * steps[j])
    assert np.max(np.abs(jac - fd) / np.linalg.norm(fd, axis=1, keepdims=True)) <= 1e-7


def test_map_kernels_use_the_layered_field():
    # gamma, log10|det Γ|, the all-rows Fisher kernel and the map all run on the same field.
    sea = Sea(200.0, 1.0)
    stations = core.dual_station(100.0, 15.0)
    plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 9)
    states = plane.states((2.0, 2.0), (100.0, 20.0)).reshape(-1, 7)
    g = core.gamma(states, stations, sea=sea)
    np.testing.assert_allclose(core.log10_abs_det_gamma(states, stations, sea=sea),
                               np.log10(np.abs(np.linalg.det(g))), atol=1e-6)
    jac = core.field_jacobian(states, stations, sea=sea)
    np.testing.assert_allclose(g[:, :6], jac.reshape(-1, 6, 7), rtol=1e-13, atol=0)  # eq. (16)
    m = core.evaluate_map(plane, stations, velocity=(2, 2), moments=(100, 20),
                          sensor=core.Sensor("E", sea=sea))
    np.testing.assert_allclose(m.value.ravel(), core.log10_abs_det_gamma(states, stations, sea=sea),
                               atol=1e-12)
    whole = core.evaluate_map(plane, stations, velocity=(2, 2), moments=(100, 20))
    assert np.min(np.abs(m.value - whole.value)) > 1e-3  # the sea changes every point
    gs = core.gamma(states, stations, sea=sea, steps=3)
    fm = core.fisher_measures(states, stations, sensor=core.Sensor("E", sea=sea))
    norms = np.linalg.norm(gs, axis=1)  # column scaling keeps slogdet accurate
    _, logdet = np.linalg.slogdet(np.einsum("pri,prj->pij", gs / norms[:, None], gs / norms[:, None]))
    expected = 0.5 * logdet / np.log(10) + np.log10(norms / core.DEFAULT_NOISE).sum(axis=1)
    np.testing.assert_allclose(fm.d_optimal, expected, atol=1e-6)


# --------------------------------------------------------------------------------------------
# invariances
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("tol", [1e-6, 1e-12])
def test_linear_in_the_moments(tol):
    # The series is linear; its truncation is decided on the total field, so each moment
    # mixture may stop at another group: linear to within the tolerance.
    sea, st = Sea(30.0, 0.3, tol), [[5.0, -3.0, 30.0]]
    base = np.array([40.0, 25.0, 12.0, 1.0, 2.0, 0.0, 0.0])
    e_h = core.dipole_field(base + [0, 0, 0, 0, 0, 1, 0], st, sea=sea)
    e_v = core.dipole_field(base + [0, 0, 0, 0, 0, 0, 1], st, sea=sea)
    both = core.dipole_field(base + [0, 0, 0, 0, 0, 70, -35], st, sea=sea)
    assert rel(both, 70 * e_h - 35 * e_v) <= 2 * tol


def test_rotation_about_the_vertical():
    sea = Sea(50.0, 0.05)
    state = np.array([60.0, 20.0, 10.0, 2.0, 1.0, 100.0, 20.0])
    st = np.array([[5.0, -3.0, 50.0], [-20.0, 30.0, 40.0]])
    a = np.deg2rad(37.0)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    turned = state.copy()
    turned[:3], turned[3:5] = rot @ state[:3], rot[:2, :2] @ state[3:5]
    e = core.dipole_field(state, st, sea=sea)
    e_turned = core.dipole_field(turned, (rot @ st.T).T, sea=sea)
    np.testing.assert_allclose(e_turned, e @ rot.T, rtol=1e-9, atol=1e-9 * np.abs(e).max())


def test_reciprocity():
    # Source and receiver exchanged: the dipole Green tensor transposes (a symmetric medium).
    sea = Sea(40.0, 0.2)
    a, b = np.array([0.0, 0.0, 3.0]), np.array([70.0, -30.0, 40.0])
    np.testing.assert_allclose(core_tensor(a, b, sea), core_tensor(b, a, sea).T, rtol=2e-6,
                               atol=2e-6 * np.abs(core_tensor(a, b, sea)).max())


def test_continuous_onto_the_seabed():
    sea = Sea(8.4, 0.4)
    state = [30.0, 10.0, 0.2, 2.0, 1.0, 100.0, 20.0]
    on = core.dipole_field(state, [[0.0, 0.0, 8.4]], sea=sea)[0]
    gaps = [rel(core.dipole_field(state, [[0.0, 0.0, 8.4 - dz]], sea=sea)[0], on)
            for dz in (1e-1, 1e-2, 1e-3)]
    assert gaps[0] > gaps[1] > gaps[2] and gaps[2] < 1e-4  # shrinks ∝ dz


# --------------------------------------------------------------------------------------------
# what the boundaries change (spec §4, §7)
# --------------------------------------------------------------------------------------------

def test_single_station_becomes_observable():
    state = [30.0, 40.0, 120.0, 2.0, 2.0, 100.0, 20.0]
    st = core.single_station(100.0)
    assert core.observable_rank(state, st, steps=3) == 6
    assert core.observable_rank(state, st, steps=3, sea=Sea(200.0, 1.0)) == 7


# --------------------------------------------------------------------------------------------
# bad input
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("args, match", [
    ((0.0, 1.0), "depth"), ((-5.0, 1.0), "depth"), ((np.inf, 1.0), "depth"), ((np.nan, 1.0), "depth"),
    (("deep", 1.0), "depth"), ((10.0, -0.1), "seabed_sigma"), ((10.0, np.inf), "seabed_sigma"),
    ((10.0, 1.0, 1e-3), "tol"), ((10.0, 1.0, 0.0), "tol"),
])
def test_bad_sea(args, match):
    with pytest.raises(ValueError, match=match):
        Sea(*args)


def test_resistivity():
    assert Sea.from_resistivity(10.0, 2.5).seabed_sigma == 0.4
    assert Sea.from_resistivity(10.0, np.inf).seabed_sigma == 0.0
    assert Sea(10.0, 0.0).seabed_resistivity == np.inf
    with pytest.raises(ValueError, match="seabed_resistivity"):
        Sea.from_resistivity(10.0, 0.0)


SEA = Sea(100.0, 1.0)
E_SEA = core.Sensor("E", sea=SEA)


def E(**medium):
    """The electric core.Sensor of a medium (sigma=, sea=, model=)."""
    return core.Sensor("E", **medium)


GOOD_STATE = [30.0, 40.0, 80.0, 2.0, 2.0, 100.0, 20.0]
GOOD_STATIONS = [[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]]
CALLS = {
    "dipole_field": lambda x, s, **k: core.dipole_field(x, s, **k),
    "field_jacobian": lambda x, s, **k: core.field_jacobian(x, s, **k),
    "gamma": lambda x, s, **k: core.gamma(x, s, **k),
    "log10_abs_det_gamma": lambda x, s, **k: core.log10_abs_det_gamma(x, s, **k),
    "observable_rank": lambda x, s, **k: core.observable_rank(x, s, **k),
    # the medium as one core.Sensor (the spec's trio and the fields above take it as keywords)
    "observability_index": lambda x, s, **k: core.observability_index(x, s, steps=3, sensor=E(**k)),
    "unobservable_direction": lambda x, s, **k: core.unobservable_direction(x, s, sensor=E(**k)),
    "fisher_measures": lambda x, s, **k: core.fisher_measures(x, s, sensor=E(**k)),
    "fisher_information": lambda x, s, **k: core.fisher_information(x, s, sensor=E(**k)),
    "crlb_covariance": lambda x, s, **k: core.crlb_covariance(x, s, sensor=E(**k)),
    "horizontal_error_ellipse": lambda x, s, **k: core.horizontal_error_ellipse(x, s, sensor=E(**k)),
}


@pytest.mark.parametrize("name", sorted(CALLS))
@pytest.mark.parametrize("where, state, stations, match", [
    ("target above the surface", [30, 40, -1.0, 2, 2, 100, 20], GOOD_STATIONS, r"target depth z -1\.0"),
    ("target below the seabed", [30, 40, 100.5, 2, 2, 100, 20], GOOD_STATIONS, r"target depth z 100\.5"),
    ("station above the surface", GOOD_STATE, [[0, 0, -2.0]], r"station depth -2\.0"),
    ("station below the seabed", GOOD_STATE, [[0, 0, 100.0], [15, 0, 101.0]], r"station depth 101\.0"),
])
def test_outside_the_water_column(name, where, state, stations, match):
    with pytest.raises(ValueError, match=match + r".*\[0, 100\.0\] m"):
        CALLS[name](state, stations, sea=SEA)
    CALLS[name](GOOD_STATE, GOOD_STATIONS, sea=SEA)  # the same call in the column works


@pytest.mark.parametrize("name", sorted(CALLS))
def test_paper_model_has_no_sea(name):
    with pytest.raises(ValueError, match="paper"):
        CALLS[name](GOOD_STATE, GOOD_STATIONS, sea=SEA, model="paper")


def test_sea_must_be_a_sea():
    with pytest.raises(ValueError, match="core.Sea"):
        core.dipole_field(GOOD_STATE, GOOD_STATIONS, sea=100.0)


def test_maps_and_design_refuse_planes_outside_the_column():
    stations = GOOD_STATIONS
    common = dict(velocity=(2, 2), moments=(100, 20), sensor=E_SEA)
    with pytest.raises(ValueError, match="target depth z 120"):
        core.evaluate_map(core.Plane("xy", (-50, 50), (-50, 50), 120.0, 4), stations, **common)
    with pytest.raises(ValueError, match="target depth z -10"):
        core.evaluate_map(core.Plane("xz", (-50, 50), (-10, 50), 0.0, 4), stations, **common)
    with pytest.raises(ValueError, match="target depth z 120"):
        core.crlb_maps(core.Plane("xy", (-50, 50), (-50, 50), 120.0, 4), stations, **common)
    region = core.Plane("xy", (-50, 50), (-50, 50), 50.0, 4)
    with pytest.raises(ValueError, match="station depth 120"):
        core.layout_criterion(core.dual_station(120.0, 10.0), region, sensor=E_SEA)
    with pytest.raises(ValueError, match="station depth 150"):
        core.spacing_curve([10.0], core.LayoutProblem(region, h=150.0, sensor=E_SEA))
    assert np.isfinite(core.layout_criterion(core.dual_station(100.0, 10.0), region, sensor=E_SEA).value)


@pytest.mark.parametrize("sb, rho_over_d, z, sz", [(1.0, 0.3, 3.0, 20.0), (1.0, 1.0, 12.0, 18.0),
                                                   (0.1, 0.5, 0.1, 20.0), (2.0, 8.0, 19.0, 0.0)])
def test_truncation_tolerance_near(sb, rho_over_d, z, sz):
    # Short ranges, where the tail is small and the shorter tail rule is used.
    depth = 20.0
    for state in ([rho_over_d * depth, 0.4 * depth, z, 1.0, 0.3, 1.0, 0.0],
                  [rho_over_d * depth, 0.4 * depth, z, 1.0, 0.3, 0.0, 1.0]):
        station = [0.0, 0.0, sz]
        ref = brute_images(np.array(state), station, depth, sb, 20000)
        assert rel(core.dipole_field(state, [station], sea=Sea(depth, sb))[0], ref) <= 1e-6


def test_sweep_takes_the_sea(tmp_path):
    from core.cli import sweep

    out = tmp_path / "sw"
    assert sweep.main(["--x", "d=5,20", "--y", "z=2,6", "--measure", "d_optimal", "--sea-depth",
                       "8.4", "--seabed-sigma", "0.4", "--set", "h=8.4", "--out", str(out),
                       "--workers", "1", "--no-progress"]) == 0
    rows = np.loadtxt(out / "sweep.csv", delimiter=",", skiprows=1)
    state = [30.0, 40.0, 6.0, *core.velocity_from_heading(2 * np.sqrt(2), 45.0), 100.0, 20.0]
    want = core.fisher_measures(state, core.dual_station(8.4, 20.0),
                                sensor=core.Sensor("E", sea=Sea(8.4, 0.4))).d_optimal
    got = rows[(rows[:, 0] == 20.0) & (rows[:, 1] == 6.0), 2]
    np.testing.assert_allclose(got, want, rtol=1e-12)
    with pytest.raises(SystemExit):  # the default h = 100 m is below an 8.4 m seabed
        sweep.main(["--x", "d=5,20", "--y", "z=2,6", "--sea-depth", "8.4", "--out", str(out)])


@pytest.mark.parametrize("depth, sb, z, sz, groups", [(130.0, 0.1, 120.0, 100.0, 3000),
                                                      (8.4, 0.01, 0.2, 8.4, 8000),
                                                      (200.0, 1.0, 120.0, 100.0, 200),
                                                      (50.0, 20.0, 10.0, 50.0, 300)])
def test_lockstep_lanes_meet_the_tolerance(depth, sb, z, sz, groups):
    # The map kernels sum 128 neighbouring points in lockstep: one group count for all, set by
    # the slowest lane, and one tail rule. Along a map row the points' own counts differ; every
    # point of the lockstep sum must still be within 1e-6 of the brute-force series, each moment
    # separately, and agree with its own one-lane sum to within the two tolerances.
    from core.kernels.gamma import LANES
    from core.model.sea import _series

    sea = Sea(depth, sb)
    x = np.linspace(-25 * depth if depth < 20 else -300, 25 * depth if depth < 20 else 300, LANES)
    station = np.array([0.0, 0.0, sz])
    for moments in ((1.0, 0.0), (0.0, 1.0), (100.0, 20.0)):
        states = np.array([[xi, 0.3 * depth, z, 2.0, 1.0, *moments] for xi in x])
        own = image_counts(states, [station], sea)[:, 0]
        lock = image_counts(states, [station], sea, lanes=LANES)[:, 0]
        assert own.min() < own.max() and np.all(lock == lock[0])  # the lanes differ on their own
        e_lock, j_lock, _ = _series(states, [station], sea, SIGMA, LANES)
        e_own, j_own, _ = _series(states, [station], sea, SIGMA, 1)
        # one lane is the per-point sum of dipole_field (compiled in another kernel, so equal
        # up to fastmath's reassociation)
        np.testing.assert_allclose(e_own, core.dipole_field(states, [station], sea=sea), rtol=1e-12)
        for k, state in enumerate(states):
            ref = brute_images(state, station, depth, sb, groups)
            assert rel(e_lock[k, 0], ref) <= 1e-6
            assert rel(e_own[k, 0], ref) <= 1e-6
        if 0.0 not in moments:
            # Jacobians, both the exact derivative of a field within tol of the series, agree
            # per row to 1e-5. (Not with a zero moment: its column is the field of a dipole
            # that the stop rule, judging the total field, does not see.)
            scale = np.linalg.norm(j_own, axis=-1, keepdims=True)
            assert np.max(np.abs(j_lock - j_own) / scale) <= 1e-5


def test_image_counts_lanes_is_checked():
    with pytest.raises(ValueError, match="lanes"):
        image_counts(GOOD_STATE, GOOD_STATIONS, SEA, lanes=0)
    with pytest.raises(ValueError, match="lanes"):
        image_counts(GOOD_STATE, GOOD_STATIONS, SEA, lanes=1000)
