"""The one measurement model (core.Sensor) and magnetic observability (spec §11).

One fixed station, a constant-velocity target with unknown moment: B alone and G alone are
structurally unobservable for any number of instants, with null directions (r0, v, 3m) and
(r0, v, 4m) (the homogeneities B(λr, λ³m) = B, G(λr, λ⁴m) = G); B + G is observable from two
instants (8 of 8 here: the state has horizontal velocity only); two gradiometers a baseline
apart are observable too.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import core

STATION = np.array([[0.0, 0.0, 0.0]])
RNG = np.random.default_rng(11)


def targets(n=20):
    """Magnetic targets 20–80 m from the station, moving, random moments (A·m²)."""
    d = RNG.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pos = d * RNG.uniform(20, 80, (n, 1))
    return np.column_stack([pos, RNG.uniform(-3, 3, (n, 2)), RNG.normal(size=(n, 3)) * 1e4])


def null_direction(states, station, power):
    """(r0, v, power·m) in state units: r0 = target − station."""
    return np.column_stack([states[:, :3] - station, states[:, 3:5], power * states[:, 5:]])


@pytest.mark.parametrize("kind, power", [("B", 3), ("G", 4)])
@pytest.mark.parametrize("steps", [1, 2, 5])
def test_one_magnetometer_or_gradiometer_is_rank_7_of_8(kind, power, steps):
    x = targets()
    rank = core.observable_rank(x, STATION, sensor=kind, steps=steps)
    rows = steps * core.KINDS[kind][1]
    assert np.all(rank == min(rows, 7))  # 7 of 8 once there are enough rows, never 8
    g = core.gamma(x, STATION, sensor=kind, steps=steps)
    n = null_direction(x, STATION[0], power)
    # Γ n = 0 to round-off, relative to ‖Γ‖ ‖n‖ column by column
    resid = np.linalg.norm(np.einsum("prj,pj->pr", g, n), axis=1)
    scale = np.linalg.norm(np.abs(g) @ np.abs(n)[..., None], axis=(1, 2))
    assert np.all(resid <= 1e-12 * scale)
    if rows > 7:
        v = core.unobservable_direction(x, STATION, sensor=kind, steps=steps)
        n_unit = n / np.linalg.norm(n, axis=1, keepdims=True)
        assert np.all(np.abs(np.abs(np.sum(v * n_unit, axis=1)) - 1.0) <= 1e-6)


def test_magnetometer_and_gradiometer_together_are_observable_from_two_instants():
    x = targets()
    assert np.all(core.observable_rank(x, STATION, sensor="BG", steps=2) == 8)
    assert np.all(core.fisher_measures(x, STATION, sensor="BG", steps=2).observable)


def test_two_gradiometers_a_baseline_apart_are_observable():
    x = targets()
    stations = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])
    assert np.all(core.observable_rank(x, stations, sensor="G", steps=2) == 8)


def test_bg_at_50_m_is_well_conditioned():
    """Spec §11 quotes σmin/σmax ≈ 6e-3 at 50 m (column-scaled, its 9-state model); ours is
    the 8-state model with noise-whitened rows: the check is that it is far above RANK_RTOL."""
    x = np.array([[50.0, 0.0, 0.0, 1.0, 1.0, 1e3, 2e3, -1e3]])
    g = core.gamma(x, STATION, sensor=core.Sensor("BG", noise=(1.0, 1.0)), steps=2)
    gs = g / np.linalg.norm(g, axis=-2, keepdims=True)
    s = np.linalg.svd(gs, compute_uv=False)
    assert s[0, -1] / s[0, 0] > 1e3 * core.RANK_RTOL


def test_paper_square_rule_is_refused_for_magnetic_kinds():
    x = targets(2)
    for call in (lambda: core.gamma(x, STATION, sensor="B"),
                 lambda: core.log10_abs_det_gamma(x, STATION, sensor="G"),
                 lambda: core.evaluate_map(core.Plane("xy", (-50, 50), (-50, 50), 10.0, 5), STATION,
                                           velocity=(1, 1), moments=(1, 2, 3), sensor="BG")):
        with pytest.raises(ValueError, match="electric paper"):
            call()


def test_electric_sensor_object_equals_old_keywords():
    x = np.array([[30.0, 40.0, 120.0, 2.0, 2.0, 100.0, 20.0]])
    st = core.dual_station(100, 15)
    sea = core.Sea(depth=200.0, seabed_sigma=1.0)
    sensor = core.Sensor("E", sigma=3.0, sea=sea)
    np.testing.assert_array_equal(core.gamma(x, st, sensor=sensor), core.gamma(x, st, sigma=3.0, sea=sea))
    a = core.fisher_measures(x, st, sensor=core.Sensor("E", noise=2e-7, sigma=3.0))
    b = core.fisher_measures(x, st, noise=2e-7, sensor=core.Sensor("E", sigma=3.0))
    np.testing.assert_array_equal(a.std, b.std)
    with pytest.raises(ValueError, match="not both"):
        core.gamma(x, st, sensor=sensor, sigma=2.0)
    with pytest.raises(ValueError, match="sensor kind"):
        core.Sensor("X")


SEA = core.Sea(depth=200.0, seabed_sigma=1.0)
_X = [[30.0, 40.0, 120.0, 2.0, 2.0, 100.0, 20.0], [-50.0, 10.0, 150.0, 1.0, -2.0, 60.0, 30.0]]
_PLANE = core.Plane("xy", (-60, 60), (-60, 60), 120.0, 5)
_REGION = core.Plane("xy", (-100, 100), (-100, 100), 120.0, 5)
_MOTION = dict(velocity=(2.0, 2.0), moments=(100.0, 20.0))
#: Every public function whose medium keywords are deprecated beside sensor=, called on its
#: own inputs with keywords ``kw``; the result as a tuple of arrays.
DEPRECATED = {
    "observability_index": lambda **kw: core.observability_index(_X, core.dual_station(100, 15), **kw),
    "unobservable_direction": lambda **kw: core.unobservable_direction(_X, [[0, 0, 100]], **kw),
    "fisher_information": lambda **kw: core.fisher_information(_X, core.dual_station(100, 15), **kw),
    "fisher_measures": lambda **kw: (lambda m: (m.d_optimal, m.std, m.observable))(
        core.fisher_measures(_X, core.dual_station(100, 15), **kw)),
    "crlb_covariance": lambda **kw: core.crlb_covariance(_X, core.dual_station(100, 15), **kw),
    "horizontal_error_ellipse": lambda **kw: tuple(vars(core.horizontal_error_ellipse(
        _X, core.dual_station(100, 15), **kw)).values()),
    "evaluate_map": lambda **kw: (lambda r: (r.value, r.observable))(core.evaluate_map(
        _PLANE, core.dual_station(100, 15), measure="d_optimal", **_MOTION, **kw)),
    "crlb_maps": lambda **kw: tuple(vars(core.crlb_maps(
        _PLANE, core.dual_station(100, 15), **_MOTION, **kw)).values()),
    "layout_criterion": lambda **kw: tuple(vars(core.layout_criterion(
        core.dual_station(100, 15), _REGION, **kw)).values()),
}


@pytest.mark.parametrize("name", sorted(DEPRECATED))
@pytest.mark.parametrize("medium", [dict(sigma=3.0, sea=SEA), dict(model="paper")],
                         ids=["sigma-sea", "model"])
def test_old_medium_keywords_warn_and_build_the_same_sensor(name, medium):
    """Issue 36 item 2: the measurement is described once, as sensor=. The old keywords sigma=,
    model=, sea= remain a deprecated convenience: a DeprecationWarning that points at the
    caller's line (here, this file), and the same results, bit for bit, as the Sensor they
    build."""
    with pytest.warns(DeprecationWarning, match="deprecated: describe the measurement once") as rec:
        old = DEPRECATED[name](**medium)
    assert {Path(w.filename).resolve() for w in rec} == {Path(__file__).resolve()}
    new = DEPRECATED[name](sensor=core.Sensor("E", **medium))
    old, new = ((r if isinstance(r, tuple) else (r,)) for r in (old, new))
    assert len(old) == len(new)
    for a, b in zip(old, new):
        np.testing.assert_array_equal(a, b)


def test_the_spec_trio_keeps_its_medium_keywords():
    """core.gamma, log10_abs_det_gamma and observable_rank take sigma=, model=, sea= without a
    warning (spec §6, their stable form), and give what the Sensor gives."""
    st = core.dual_station(100, 15)
    for f in (core.gamma, core.log10_abs_det_gamma, core.observable_rank):
        for medium in (dict(sigma=3.0, sea=SEA), dict(model="paper")):
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                old = f(_X, st, **medium)
            np.testing.assert_array_equal(old, f(_X, st, sensor=core.Sensor("E", **medium)))


def test_fisher_is_whitened_gamma_and_crlb_its_inverse():
    x = targets(5)
    stations = np.array([[0.0, 0.0, 0.0], [3.0, 1.0, 0.0]])
    sensor = core.Sensor("BG", noise=(0.05, 0.02))
    g = core.gamma(x, stations, sensor=sensor, steps=3)
    w = np.tile(np.repeat([[0.05], [0.02]], [3, 5], axis=0)[:, 0], 2 * 3)
    f = core.fisher_information(x, stations, sensor=sensor, steps=3)
    np.testing.assert_allclose(f, np.einsum("pri,prj->pij", g / w[:, None], g / w[:, None]), rtol=1e-12)
    cov, ok = core.crlb_covariance(x, stations, sensor=sensor, steps=3)
    assert ok.all() and cov.shape == (5, 8, 8)
    eye = np.einsum("pij,pjk->pik", cov, f)
    assert np.max(np.abs(eye - np.eye(8))) <= 1e-6


def test_magnetic_maps_and_crlb_maps():
    plane = core.Plane("xy", (-60, 60), (-60, 60), 15.0, 9)
    kw = dict(velocity=(1.0, 1.0), moments=(1e3, -2e3, 5e2), steps=2)
    m_b = core.evaluate_map(plane, STATION, measure="crlb_position", sensor="B", **kw)
    m_bg = core.evaluate_map(plane, STATION, measure="crlb_position", sensor="BG", **kw)
    assert not m_b.observable.any()  # one magnetometer: veiled everywhere
    assert m_bg.observable.all() and np.all(np.isfinite(m_bg.value))
    e = core.crlb_maps(plane, STATION, sensor="BG", **kw)
    np.testing.assert_allclose(e.position, m_bg.value, rtol=1e-10)
    # the map is the pointwise CRLB
    u, v = plane.axes
    x = np.array([u[3], v[5], 15.0, 1.0, 1.0, 1e3, -2e3, 5e2])
    point = core.fisher_measures(x, STATION, sensor="BG", steps=2).position_std
    np.testing.assert_allclose(m_bg.value[5, 3], point, rtol=1e-12)


def magnetic_track(steps=40, T=1.0):
    """A target passing 15 m from the origin at 2 m/s, moment (A·m²) constant."""
    t = np.arange(steps) * T
    x = np.column_stack([-40 + 2.0 * t, np.full(steps, 15.0), np.full(steps, 10.0),
                         np.full(steps, 2.0), np.zeros(steps),
                         np.tile([2e3, -1e3, 3e3], (steps, 1))])
    return x


def test_pcrlb_takes_the_magnetic_kinds():
    track = magnetic_track()
    det = dict(sigma_a=0.0, alpha=0.0)  # deterministic: the information is Γᵀ R⁻¹ Γ
    b = core.pcrlb(track, core.SensorModel([[0.0, 0.0, 0.0]], noise=0.01, kind="B"), **det)
    bg = core.pcrlb(track, core.SensorModel([[0.0, 0.0, 0.0]], noise=(0.01, 0.01), kind="BG"), **det)
    assert not b.observable.any()  # one magnetometer: the scale symmetry, whatever the track
    assert bg.observable[1:].all() and bg.cov.shape == (40, 8, 8)
    # deterministic PCRLB at step k = the Fisher bound of Γ over the steps 0 … k, seen from step 0
    k = 5
    f = core.fisher_information(track[0], [[0.0, 0.0, 0.0]], steps=k + 1,
                                sensor=core.Sensor("BG", noise=(0.01, 0.01)))
    F, _ = core.dwna_model(1.0, 0.0, 0.0, n_states=8)
    Fk = np.linalg.matrix_power(F, k)
    cov0 = np.linalg.inv(f)
    np.testing.assert_allclose(bg.cov[k], Fk @ cov0 @ Fk.T, rtol=1e-6,
                               atol=1e-9 * np.abs(bg.cov[k]).max())


def test_sensor_model_carries_the_kind():
    m = core.SensorModel([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], noise=(0.1, 0.02), kind="BG", baseline=0.5)
    assert m.n_meas == 16 and m.n_states == 8
    np.testing.assert_allclose(np.diag(m.R)[:8], [0.1**2] * 3 + [0.02**2] * 5, rtol=1e-15)
    x = magnetic_track(2)
    h, J = m.h_and_jacobian(x)
    h_ref, J_ref = core.magnetic_jacobian(x, m.stations, sensor="BG", baseline=0.5)
    np.testing.assert_allclose(h, h_ref.reshape(2, -1), rtol=1e-12, atol=1e-12 * np.abs(h_ref).max())
    np.testing.assert_array_equal(J, J_ref.reshape(2, 16, 8))
    with pytest.raises(ValueError, match="axes=2"):
        core.SensorModel([[0.0, 0.0, 0.0]], axes=2, kind="B", noise=0.1)


def test_layout_criterion_takes_the_sensor():
    region = core.Plane("xy", (-40, 40), (-40, 40), 12.0, 7)
    kw = dict(velocity=(1.0, 1.0), moments=(1e3, -2e3, 5e2), steps=3)
    one_b = core.layout_criterion([[0.0, 0.0, 0.0]], region, sensor="B", **kw)
    two_b = core.layout_criterion([[0.0, 0.0, 0.0], [20.0, 0.0, 0.0]], region, sensor="B", **kw)
    assert one_b.observable_fraction == 0.0 and two_b.observable_fraction == 1.0
    assert two_b.value > one_b.value
    bg = core.layout_criterion([[0.0, 0.0, 0.0]], region, sensor="BG", criterion="area_crlb",
                               threshold=1.0, **kw)
    assert bg.observable_fraction == 1.0


def test_magnetic_maps_mask_targets_that_reach_a_station():
    """A plane through the station: grid points whose track reaches it within Γ's instants are
    NaN in the maps (as the electric maps mask stations), not a ValueError."""
    plane = core.Plane("xy", (-4, 4), (-4, 4), 0.0, 5)  # spacing 2 m, velocity (2, 2) m/s
    kw = dict(velocity=(2.0, 2.0), moments=(1e3, -2e3, 5e2), steps=2)
    m = core.evaluate_map(plane, STATION, measure="crlb_position", sensor="BG", **kw)
    e = core.crlb_maps(plane, STATION, sensor="BG", **kw)
    # (0, 0) is on the station; (−2, −2) reaches it at the second instant
    for i, j in ((2, 2), (1, 1)):
        assert np.isnan(m.value[i, j]) and not m.observable[i, j] and np.isnan(e.position[i, j])
    assert np.isfinite(m.value[0, 4])
    np.testing.assert_allclose(e.position, m.value, rtol=1e-10)


def test_layout_optimisers_take_the_sensor():
    """The spacing of two magnetometers: one is unobservable (a D-optimal floor), so the curve
    over d rises from the tiny spacings; the optimisers run on the magnetic kind."""
    region = core.Plane("xy", (-30, 30), (-30, 30), 12.0, 5)
    kw = dict(velocity=(1.0, 1.0), moments=(1e3, -2e3, 5e2), h=0.0, sensor="B")
    problem = core.LayoutProblem(region, **kw)
    curve = core.spacing_curve([0.5, 5.0, 20.0], problem)
    assert np.all(np.isfinite(curve)) and curve[1] > curve[0]
    best = core.best_spacing(problem, d_range=(1.0, 40.0), n_curve=5)
    assert 1.0 <= best.d <= 40.0
    lay = core.optimise_layout("line", 2, problem, d_range=(1.0, 40.0), n_curve=5)
    assert lay.stations.shape == (2, 3) and np.isfinite(lay.value)
    free = core.optimise_layout("free", 2, problem, x0=[[-5.0, 0.0], [5.0, 0.0]], maxfev=30)
    assert free.value >= core.layout_criterion(
        [[-5.0, 0.0, 0.0], [5.0, 0.0, 0.0]], region, velocity=(1.0, 1.0),
        moments=(1e3, -2e3, 5e2), sensor="B").value - 1e-9
