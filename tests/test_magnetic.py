"""Magnetic dipole physics (spec §11) against independent references.

- magpylib's dipole (its μ0 is CODATA's, 1.3e-10 from 4π·1e-7): the field, central differences
  of its field for the gradient tensor, differences of its magnetometers for a finite baseline;
- complex step through a closed form written here (magpylib drops imaginary parts) for the
  Jacobians;
- the electric kernel where the two forms coincide (κ = 1/4πσ ↔ μ0/4π);
- Euler's homogeneity, the tensor invariants' closed form, the scale symmetries.
"""

from __future__ import annotations

import magpylib
import numpy as np
import pytest

import core

RNG = np.random.default_rng(2026_12_02)


def random_states(n, rng=RNG, rmin=1.0, rmax=60.0):
    """Targets at 1–60 m from the origin in random directions, random moments and velocities."""
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pos = d * rng.uniform(rmin, rmax, (n, 1))
    vel = rng.uniform(-3, 3, (n, 2))
    mom = rng.normal(size=(n, 3)) * 10 ** rng.uniform(0, 4, (n, 1))
    return np.column_stack([pos, vel, mom])


def magpylib_b(states, station):
    """magpylib's field (nT) at one station for every state."""
    return np.array([magpylib.misc.Dipole(moment=x[5:], position=x[:3]).getB(station) * 1e9
                     for x in states])


def closed_b(x, s):
    """The closed form B (nT) of one state x (8,) at sensor s (3,), complex-safe."""
    r = np.asarray(s) - x[:3]
    m = x[5:8]
    d = np.sqrt(np.sum(r * r))
    return 100.0 * (3.0 * np.sum(m * r) * r / d**5 - m / d**3)


def closed_g(x, s):
    """The closed form G_ij = ∂B_i/∂s_j (nT/m), complex-safe."""
    r = np.asarray(s) - x[:3]
    m = x[5:8]
    d = np.sqrt(np.sum(r * r))
    q = np.sum(m * r)
    return 300.0 / d**5 * (np.outer(m, r) + np.outer(r, m) + q * np.eye(3)
                           - 5.0 * q * np.outer(r, r) / d**2)


G_INDEX = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2))


def closed_h(x, s, sensor, baseline=0.0):
    """Measurement vector of one station in the kernel's order, complex-safe."""
    parts = []
    if "B" in sensor:
        parts.append(closed_b(x, s))
    if "G" in sensor:
        if baseline > 0:
            e = np.eye(3)
            g = np.column_stack([(closed_b(x, s + baseline / 2 * e[j]) - closed_b(x, s - baseline / 2 * e[j]))
                                 / baseline for j in range(3)])
        else:
            g = closed_g(x, s)
        parts.append(np.array([g[i, j] for i, j in G_INDEX]))
    return np.concatenate(parts)


def complex_step_jacobian(f, x, h=1e-30):
    """∂f/∂x by complex step: exact to round-off, no subtraction."""
    cols = []
    for k in range(x.size):
        xc = x.astype(complex)
        xc[k] += 1j * h
        cols.append(np.imag(f(xc)) / h)
    return np.column_stack(cols)


def test_field_matches_magpylib():
    states = random_states(200)
    station = np.array([0.0, 0.0, 0.0])
    ours = core.magnetic_field(states, station[None])[:, 0]
    ref = magpylib_b(states, station)
    rel = np.linalg.norm(ours - ref, axis=1) / np.linalg.norm(ref, axis=1)
    assert rel.max() <= 1e-9  # magpylib's μ0 differs from 4π·1e-7 by 1.3e-10


def test_field_broadcasts_like_one_by_one_calls():
    states = random_states(12).reshape(3, 4, 8)
    stations = np.array([[0.0, 0.0, 0.0], [80.0, 5.0, -3.0]])
    b = core.magnetic_field(states, stations)
    assert b.shape == (3, 4, 2, 3)
    one = core.magnetic_field(states[1, 2], stations[1:])
    np.testing.assert_array_equal(b[1, 2, 1:], one)


def assert_round_off_equal(actual, desired):
    """Equal to round-off. Bit equality holds when both kernels come from the same compilation
    (both compiled in this process, or both loaded from numba's cache); on a cold cache one twin
    may be compiled here and the other loaded from what another process wrote, and the two differ
    in the last bits (measured: 1.1e-11 absolute on entries of order 0.1, 1.7e-12 relative). 1e-9
    relative plus 1e-12 of the array's largest entry is ~100x that, and a wrong row, lane or
    station changes entries at order one."""
    scale = np.nanmax(np.abs(desired))
    np.testing.assert_allclose(actual, desired, rtol=1e-9, atol=1e-12 * scale)


@pytest.mark.parametrize("baseline", [None, 0.5])
def test_serial_and_parallel_kernels_agree(baseline):
    """Above ``BLOCK`` points the fronts run the parallel kernels, at or below it their serial
    twins: the same numbers (to round-off, see :func:`assert_round_off_equal`) for the field, the
    tensor and the Jacobian rows."""
    from core.kernels.magnetic import BLOCK
    states = random_states(2 * BLOCK + 37)
    stations = np.array([[0.0, 0.0, 0.0], [3.0, -2.0, 1.0]])
    whole_b = core.magnetic_field(states, stations)
    whole_g = core.gradient_tensor(states, stations, baseline=baseline)
    whole_h, whole_j = core.magnetic_jacobian(states, stations, sensor="BG", baseline=baseline)
    for lo in range(0, len(states), BLOCK):
        part = states[lo:lo + BLOCK]
        assert_round_off_equal(core.magnetic_field(part, stations), whole_b[lo:lo + BLOCK])
        assert_round_off_equal(core.gradient_tensor(part, stations, baseline=baseline),
                               whole_g[lo:lo + BLOCK])
        h, j = core.magnetic_jacobian(part, stations, sensor="BG", baseline=baseline)
        assert_round_off_equal(h, whole_h[lo:lo + BLOCK])
        assert_round_off_equal(j, whole_j[lo:lo + BLOCK])


def test_tensor_matches_central_differences_of_magpylib():
    states = random_states(60, rmin=2.0)
    station = np.array([0.0, 0.0, 0.0])
    ours = core.gradient_tensor(states, station[None])[:, 0]
    h = 1e-4
    for x, g in zip(states, ours):
        d = magpylib.misc.Dipole(moment=x[5:], position=x[:3])
        fd = np.column_stack([(d.getB(station + h * e) - d.getB(station - h * e)) * 1e9 / (2 * h)
                              for e in np.eye(3)])
        assert np.linalg.norm(g - fd) <= 1e-7 * np.linalg.norm(g)


def test_tensor_symmetric_and_traceless():
    g = core.gradient_tensor(random_states(300), [[0.0, 0.0, 0.0]])[:, 0]
    scale = np.linalg.norm(g, axis=(1, 2))
    assert np.max(np.linalg.norm(g - np.swapaxes(g, 1, 2), axis=(1, 2)) / scale) <= 1e-14
    assert np.max(np.abs(np.trace(g, axis1=1, axis2=2)) / scale) <= 1e-14


@pytest.mark.parametrize("sensor", ["B", "G", "BG"])
@pytest.mark.parametrize("baseline", [None, 0.5])
def test_jacobian_matches_complex_step(sensor, baseline):
    states = random_states(25, rmin=3.0)
    stations = np.array([[0.0, 0.0, 0.0], [4.0, -2.0, 1.0]])
    h, jac = core.magnetic_jacobian(states, stations, sensor=sensor, baseline=baseline)
    L = baseline or 0.0
    for p, x in enumerate(states):
        for s, st in enumerate(stations):
            ref_h = closed_h(x, st, sensor, L)
            ref_j = complex_step_jacobian(lambda xc: closed_h(xc, st, sensor, L), x)
            assert np.linalg.norm(h[p, s] - ref_h) <= 1e-12 * np.linalg.norm(ref_h)
            # per row: the Jacobian's rows have very different scales (B vs G, position vs moment)
            err = np.linalg.norm(jac[p, s] - ref_j, axis=1)
            assert np.all(err <= 1e-10 * np.linalg.norm(ref_j, axis=1))


def test_magnetic_kernel_equals_electric_where_forms_coincide():
    """E = κ (3(p·R)R/D⁵ − p/D³), R = station − target; B the same with κ → 100 nT·m/A.
    With σ = 1/(400π) S/m (κ = 100) and m = (Ph cos θ, Ph sin θ, Pv) they are one function."""
    rng = np.random.default_rng(7)
    e_states = np.column_stack([rng.uniform(-200, 200, (50, 3)), rng.uniform(-3, 3, (50, 2)),
                                rng.uniform(10, 200, 50), rng.uniform(-100, 100, 50)])
    theta = np.arctan2(e_states[:, 4], e_states[:, 3])
    m = np.column_stack([e_states[:, 5] * np.cos(theta), e_states[:, 5] * np.sin(theta),
                         e_states[:, 6]])
    m_states = np.column_stack([e_states[:, :5], m])
    stations = np.array([[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]])
    sigma = 1.0 / (400.0 * np.pi)
    e = core.dipole_field(e_states, stations, sigma=sigma)
    b = core.magnetic_field(m_states, stations)
    assert np.max(np.linalg.norm(e - b, axis=-1) / np.linalg.norm(b, axis=-1)) <= 1e-12
    # and the position columns of their Jacobians: ∂E/∂x and ∂B/∂x = −G
    je = core.field_jacobian(e_states, stations, sigma=sigma)[..., :3]
    jb = core.magnetic_jacobian(m_states, stations, sensor="B")[1][..., :3]
    assert np.max(np.linalg.norm(je - jb, axis=(-2, -1)) / np.linalg.norm(jb, axis=(-2, -1))) <= 1e-12


def test_scale_symmetries():
    """B(λr, λ³m) = B and G(λr, λ⁴m) = G (spec §11): the structural null directions."""
    x = random_states(20)
    lam = 1.7
    xb, xg = x.copy(), x.copy()
    xb[:, :3] *= lam
    xb[:, 5:] *= lam**3
    xg[:, :3] *= lam
    xg[:, 5:] *= lam**4
    st = [[0.0, 0.0, 0.0]]
    np.testing.assert_allclose(core.magnetic_field(xb, st), core.magnetic_field(x, st), rtol=1e-13, atol=0)
    np.testing.assert_allclose(core.gradient_tensor(xg, st), core.gradient_tensor(x, st), rtol=1e-12,
                               atol=1e-13 * np.abs(core.gradient_tensor(x, st)).max())


def test_euler_locates_the_source():
    states = random_states(100, rmin=2.0)
    station = np.array([[3.0, -1.0, 2.0]])
    b = core.magnetic_field(states, station)[:, 0]
    g = core.gradient_tensor(states, station)[:, 0]
    r = core.euler_locate(b, g)
    truth = station[0] - states[:, :3]
    # G's condition number grows as m approaches the plane ⊥ r; these random cases stay ≤ ~1e4
    assert np.max(np.linalg.norm(r - truth, axis=1) / np.linalg.norm(truth, axis=1)) <= 1e-9


def test_euler_refuses_a_singular_tensor():
    # m ⊥ r: det G = 0 (spec §11)
    x = [0.0, 0.0, 0.0, 1.0, 0.0, 10.0, 0.0, 0.0]
    st = [[0.0, 0.0, 20.0]]
    b, g = core.magnetic_field(x, st), core.gradient_tensor(x, st)
    with pytest.raises(ValueError, match="singular"):
        core.euler_locate(b, g)


def test_tensor_invariants_closed_form():
    """Eigenvalues k·{(−c ± √(4+5c²))/2, c}, k = 300|m|/r⁴, c = m̂·r̂; NSS = k (spec §11)."""
    states = random_states(100)
    g = core.gradient_tensor(states, [[0.0, 0.0, 0.0]])[:, 0]
    inv = core.tensor_invariants(g)
    r = -states[:, :3]
    m = states[:, 5:]
    rn, mn = np.linalg.norm(r, axis=1), np.linalg.norm(m, axis=1)
    k = 300.0 * mn / rn**4
    c = np.sum(m * r, axis=1) / (mn * rn)
    s = np.sqrt(4 + 5 * c**2)
    expected = k[:, None] * np.column_stack([(-c + s) / 2, c, (-c - s) / 2])
    np.testing.assert_allclose(inv.eigenvalues, expected, rtol=0, atol=1e-12 * k.max())
    assert np.max(np.abs(inv.nss - k) / k) <= 1e-7  # √ of a difference: loses ~half the digits near c² → 1
    np.testing.assert_allclose(inv.i2, np.linalg.det(g), rtol=1e-10, atol=1e-12 * k.max() ** 3)


def test_finite_baseline_is_the_difference_of_magpylib_magnetometers():
    states = random_states(30, rmin=3.0)
    station = np.array([1.0, 2.0, -1.0])
    L = 0.5
    ours = core.gradient_tensor(states, station[None], baseline=L)[:, 0]
    for x, g in zip(states, ours):
        d = magpylib.misc.Dipole(moment=x[5:], position=x[:3])
        ref = np.column_stack([(d.getB(station + L / 2 * e) - d.getB(station - L / 2 * e)) * 1e9 / L
                               for e in np.eye(3)])
        assert np.linalg.norm(g - ref) <= 1e-9 * np.linalg.norm(ref)


def test_finite_baseline_error_is_second_order_in_the_baseline():
    """The array's central differences miss the point tensor by O((L/r)²): halving L quarters it."""
    states = random_states(50, rmin=5.0)
    st = [[0.0, 0.0, 0.0]]
    point = core.gradient_tensor(states, st)[:, 0]
    errs = []
    for L in (0.4, 0.2):
        g = core.gradient_tensor(states, st, baseline=L)[:, 0]
        errs.append(np.linalg.norm(g - point, axis=(1, 2)) / np.linalg.norm(point, axis=(1, 2)))
    ratio = errs[0] / errs[1]
    assert np.all(np.abs(ratio - 4.0) <= 0.05)  # 4 + O((L/r)²), L/r ≤ 0.08 here
    r = np.linalg.norm(states[:, :3], axis=1)
    coef = errs[0] / (0.4 / r) ** 2  # relative error per (L/r)²: spec §11 quotes ≈ 0.83
    assert 0.1 < np.median(coef) < 3.0


@pytest.mark.parametrize("bad, match", [
    (np.zeros(7), r"shape \(\.\.\., 8\)"),
    ([0, 0, 0, 1, 0, np.nan, 0, 0], "finite"),
])
def test_bad_states_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        core.magnetic_field(bad, [[0.0, 0.0, 10.0]])


def test_target_on_station_or_inside_the_array_is_refused():
    with pytest.raises(ValueError, match="singular"):
        core.magnetic_field([0, 0, 10, 1, 0, 1, 1, 1], [[0.0, 0.0, 10.0]])
    with pytest.raises(ValueError, match="baseline"):
        core.gradient_tensor([0, 0, 10.2, 1, 0, 1, 1, 1], [[0.0, 0.0, 10.0]], baseline=0.5)
    with pytest.raises(ValueError, match="baseline"):
        core.gradient_tensor([0, 0, 20, 1, 0, 1, 1, 1], [[0.0, 0.0, 10.0]], baseline=-1)
    with pytest.raises(ValueError, match="sensor kind"):
        core.magnetic_jacobian([0, 0, 20, 1, 0, 1, 1, 1], [[0.0, 0.0, 10.0]], sensor="E")
