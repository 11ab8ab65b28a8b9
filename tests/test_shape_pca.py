"""core.shape: PCA shape on exact point sets, and the truth models' geometry."""

import numpy as np
import pytest

from core.shape.pca import DISC_FACTOR, PLANE_RATIO, axis_angle_deg, pca_shape
from core.shape.targets import Outliers, Pass, Target, attitude_matrix


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def test_line_recovers_axis_span_and_scale():
    """4 points at the centres of 4 equal segments of a rod of length L along a tilted axis:
    span 3L/4, main scale N/(N−1)·span = L exactly, axis to 1e-12°."""
    a = _unit([1.0, -2.0, 0.5])
    c = np.array([3.0, -1.0, 2.0])
    L = 2.4
    pts = c + np.outer((np.arange(4) + 0.5) / 4 * L - L / 2, a)
    s = pca_shape(pts)
    assert s.kind == "line"
    np.testing.assert_allclose(s.centroid, c, atol=1e-14)
    assert s.span == pytest.approx(0.75 * L, rel=1e-13)
    assert s.main_scale == pytest.approx(L, rel=1e-13)
    assert axis_angle_deg(s.axis, a) < 1e-10
    np.testing.assert_allclose(s.eigenvalues[1:], 0.0, atol=1e-14)


def test_square_is_a_plane_with_its_diagonal_and_normal():
    """A square of diagonal L: λ1 = λ2 = L²/6 (N − 1 normalisation), λ3 = 0, verdict plane,
    axis = the normal, diameter = DISC_FACTOR · L; rotated anywhere."""
    L = 1.3
    sq = L / 2 * np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], float)
    Rm = attitude_matrix(0.3, -0.7, 1.9)
    s = pca_shape(sq @ Rm.T + [1, 2, 3])
    assert s.kind == "plane"
    np.testing.assert_allclose(s.eigenvalues, [L**2 / 6, L**2 / 6, 0.0], atol=1e-14)
    assert axis_angle_deg(s.axis, Rm[:, 2]) < 1e-10
    assert s.disc_diameter == pytest.approx(DISC_FACTOR * L, rel=1e-13)
    assert s.main_scale == s.disc_diameter


def test_verdict_threshold_and_broadcasting():
    """λ2/λ1 just below / above PLANE_RATIO flips the verdict; a stack gives per-set results."""
    def rect(w):  # 2 × w rectangle: λ2/λ1 = (w/2)²
        return np.array([[1, w / 2, 0], [1, -w / 2, 0], [-1, w / 2, 0], [-1, -w / 2, 0]], float)
    w_edge = 2 * np.sqrt(PLANE_RATIO)
    stack = np.stack([rect(w_edge * 0.99), rect(w_edge * 1.01)])
    s = pca_shape(stack)
    assert s.kind.tolist() == ["line", "plane"]
    assert s.main_scale.shape == (2,)
    with pytest.raises(ValueError, match="N ≥ 2"):
        pca_shape(np.zeros((1, 3)))


def test_attitude_convention():
    """Rz(yaw) Ry(pitch) Rx(roll): orthonormal, det 1, and each angle alone is the right-hand
    rotation about its axis."""
    R = attitude_matrix(np.pi / 6, np.pi / 4, np.pi / 3)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(attitude_matrix(np.pi / 2, 0, 0) @ [0, 1, 0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(attitude_matrix(0, 0, np.pi / 2) @ [1, 0, 0], [0, 1, 0], atol=1e-15)


def test_seed003_target_and_pass():
    """Seed 003's cylinder: 2400 cells of 0.1 m, |M| = 1.42e4 A·m² (spec §11: ≈ 1.4e4), centroid
    at the origin, axis R e_z; the pass's closest approach is √50 m and it ends at x = +40 m."""
    t = Target()
    assert t.positions.shape == (2400, 3)
    assert np.linalg.norm(t.total_moment) == pytest.approx(2400 * np.sqrt(35), rel=1e-12)
    np.testing.assert_allclose(t.centroid, 0.0, atol=1e-12)
    s = pca_shape(t.positions)
    assert s.kind == "line" and axis_angle_deg(s.axis, t.axis) < 1e-8
    # 30 layers 0.1 m apart: the cells' span is 2.9 m; the truth is the body's H = 3 m
    assert s.span == pytest.approx(2.9, abs=1e-9) and t.main_scale == 3.0
    p = Pass()
    assert p.closest_approach() == pytest.approx(np.sqrt(50.0))
    assert p.positions[-1].tolist() == [40.0, 5.0, -5.0]
    assert p.with_closest_approach(15.0).closest_approach() == pytest.approx(15.0)


def test_hollow_and_disc_targets():
    solid = Target(height=3.0, radius=0.5, attitude=(0, 0, 0))
    shell = Target(height=3.0, radius=0.5, inner_height=2.8, inner_radius=0.4, attitude=(0, 0, 0))
    assert 0 < shell.positions.shape[0] < solid.positions.shape[0]
    z = np.abs(shell.positions[:, 2])
    assert np.any(z < 1.4) and np.any(z > 1.4)  # walls and end caps remain
    inner = (np.hypot(shell.positions[:, 0], shell.positions[:, 1]) < 0.4) & (np.abs(shell.positions[:, 2]) < 1.4)
    assert not inner.any()
    disc = Target(height=0.2, radius=1.0)
    assert disc.kind == "plane" and disc.main_scale == 2.0
    with pytest.raises(ValueError, match="cavity must fit"):
        Target(inner_height=1.0, inner_radius=0.6)


def test_outliers_hit_the_samples_nearest_their_x():
    p = Pass()
    o = Outliers(at_x=(-20.0, -10.0, 0.0), size=100.0, components=(0, 3))
    assert o.samples(p) == [20, 30, 40]
    clean = np.ones((81, 5))
    clean[:, 3] = -1
    z = np.zeros((2, 81, 5))
    o.apply(z, clean, 0.01, p)
    assert z[0, 20].tolist() == [1.0, 0, 0, -1.0, 0] and z[1, 40, 0] == 1.0 and z[:, 21].sum() == 0
