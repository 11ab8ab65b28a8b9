"""Maps over planes and difference maps."""

import numpy as np
import pytest

import core
from core.observability import maps

DUAL15 = core.dual_station(100, 15)


@pytest.mark.parametrize("measure", sorted(core.MEASURES))
def test_map_equals_pointwise_calls(measure):
    plane = core.Plane("xz", (-300, 300), (100, 400), 50.0, 7)
    r = core.evaluate_map(plane, DUAL15, velocity=(2, 2), moments=(100, 20), measure=measure)
    states = plane.states((2, 2), (100, 20))
    if measure == "log10_det":
        ref = core.log10_abs_det_gamma(states, DUAL15)
    elif measure == "log10_eta":
        ref = core.observability_index(states, DUAL15)
    else:
        m = core.fisher_measures(states, DUAL15)
        ref = m.d_optimal if measure == "d_optimal" else m.position_std
    np.testing.assert_array_equal(r.value, ref)
    assert r.value.shape == (7, 7)


def test_plane_axes_and_fixed_coordinate():
    plane = core.Plane("xz", (-10, 10), (100, 200), 50.0, 3)
    s = plane.states((1, 0), (5, 6))
    np.testing.assert_array_equal(s[0, :, 0], [-10, 0, 10])  # columns: x
    np.testing.assert_array_equal(s[:, 0, 2], [100, 150, 200])  # rows: z
    assert np.all(s[..., 1] == 50.0)


def test_station_points_are_masked_not_raised():
    plane = core.Plane("xy", (-10, 10), (-10, 10), 100.0, 3)  # (0, 0, 100) is a grid point
    r = core.evaluate_map(plane, core.single_station(100), velocity=(2, 2), moments=(100, 20))
    assert np.isnan(r.value[1, 1]) and not r.observable[1, 1]
    assert np.isfinite(r.value).sum() == 8


def test_single_station_map_is_flagged_everywhere():
    plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 21)
    r = core.evaluate_map(plane, core.single_station(100), velocity=(2, 2), moments=(100, 20))
    assert not r.observable.any()
    assert np.isfinite(r.value).all()  # round-off values kept, for display as such
    dual = core.evaluate_map(plane, DUAL15, velocity=(2, 2), moments=(100, 20))
    assert dual.observable.mean() > 0.95


def test_chunked_map_equals_one_chunk(monkeypatch):
    plane = core.Plane("xy", (-300, 300), (-300, 300), 120.0, 40)
    whole = core.evaluate_map(plane, DUAL15, velocity=(2, 2), moments=(100, 20))
    monkeypatch.setattr(maps, "CHUNK_POINTS", 100)  # 2 rows per chunk
    chunked = core.evaluate_map(plane, DUAL15, velocity=(2, 2), moments=(100, 20))
    np.testing.assert_array_equal(whole.value, chunked.value)


def test_positive_difference_from_logs_without_underflow():
    a = np.array([-400.0, -400.0, -50.0, 3.0, -np.inf, -20.0])
    b = np.array([-401.0, -399.0, -50.0, -np.inf, -3.0, -20.0 - 1e-12])
    d = core.log10_positive_difference(a, b)
    # 10^-400 − 10^-401 = 0.9 · 10^-400
    np.testing.assert_allclose(d[0], -400 + np.log10(0.9), atol=1e-12)
    assert np.isnan(d[1]) and np.isnan(d[2]) and np.isnan(d[4])  # Δ ≤ 0 or A = 0: blank
    assert d[3] == 3.0  # B = 0
    # tiny positive gap: log10(10^a (1 − 10^-1e-12)) computed with expm1, not cancelled to -inf
    gap = b[5] - a[5]  # ≈ -1e-12 (as rounded in float64)
    np.testing.assert_allclose(d[5], a[5] + np.log10(-gap * np.log(10)), atol=1e-9)
    # representable case agrees with direct subtraction
    x, y = np.array([-3.2]), np.array([-3.9])
    np.testing.assert_allclose(core.log10_positive_difference(x, y),
                               np.log10(10**x - 10**y), rtol=1e-13)


def test_log_ratio():
    out = core.log10_ratio([1.0, -np.inf, 2.0], [0.5, 1.0, np.nan])
    assert out[0] == 0.5 and np.isnan(out[1]) and np.isnan(out[2])


@pytest.mark.parametrize("kwargs,message", [
    (dict(kind="yz"), "plane kind"),
    (dict(n=1), "resolution"),
    (dict(n=5000), "resolution"),
    (dict(u=(5, -5)), "min < max"),
    (dict(fixed=np.nan), "fixed coordinate"),
])
def test_plane_rejects_bad_input(kwargs, message):
    args = dict(kind="xy", u=(-1, 1), v=(-1, 1), fixed=100.0, n=10) | kwargs
    with pytest.raises(ValueError, match=message):
        core.Plane(**args)


def test_unknown_measure():
    plane = core.Plane("xy", (-1, 1), (-1, 1), 120.0, 2)
    with pytest.raises(ValueError, match="measure must be one of"):
        core.evaluate_map(plane, DUAL15, velocity=(1, 1), moments=(1, 1), measure="volume")
