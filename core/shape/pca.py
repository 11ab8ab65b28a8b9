"""Shape from a few dipoles: principal components of their positions (seed 003 §3).

The filter's N dipoles (seed 003: 4) spread over the target as they fit its near field. Their
positions' covariance C = Σ (r_i − r̄)(r_i − r̄)ᵀ / (N − 1) (seed 003 eq. (16), whose
normalisation is lost; N − 1 is used here and every formula below is stated with it) has
eigenvalues λ1 ≥ λ2 ≥ λ3 and unit eigenvectors u1, u2, u3.

- **Line** (a cylinder, H > R in seed 003's terms): the dipoles lie along u1, the axis. With the
  projections p_i = r_i · u1 (eq. (17)), the main scale is L = N / (N − 1) · (max p − min p)
  (eq. (18)): N dipoles at the centres of N equal segments of a rod of length L span
  (N − 1) L / N.
- **Plane** (a disc, H < R): the dipoles lie in the plane of u1, u2; u3 is the disc's axis.
  Seed 003 fits a disc of radius R by 4 circles of radius R/2 at the corners of a square of
  diagonal L (its Fig. 2): tangent to the disc and crossing each other, L = R (eq. (19):
  r = L/2); tangent to each other and crossing the disc, L = √2 R (eq. (20)). Its combination
  (eq. (22)) is lost; we take the mean of the two diameters, D = (2 + √2)/2 · L ≈ 1.707 L. The
  diagonal L of a square is 2 × its points' RMS distance from the centroid, so for any N
  L = 2 √(Σ_i |P (r_i − r̄)|² / N) with P the projection on the (u1, u2) plane
  (= √((N − 1)(λ1 + λ2) · 4 / N); for the square, λ1 = λ2 = L² / 6, eq. (21)).
- **Second-moment read of a line**: L₂ = √(12 λ1 N / (N + 1)), the rod whose N segment centres
  have the dipoles' spread along u1: L for evenly spaced dipoles, from every dipole's projection
  where the span uses the two end ones only (its bound is far lower: :mod:`core.shape.bound`).
- **Verdict**: "line" if λ2 / λ1 < :data:`PLANE_RATIO` (the second principal spread is less
  than half the first), else "plane".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["DISC_FACTOR", "PLANE_RATIO", "ShapeEstimate", "axis_angle_deg", "pca_shape"]

#: λ2 / λ1 at and above which the dipoles are read as a plane (disc), below as a line.
PLANE_RATIO = 0.25
#: Disc diameter per square diagonal: the mean of seed 003's two covering strategies (2 and √2).
DISC_FACTOR = (2.0 + np.sqrt(2.0)) / 2.0


@dataclass(frozen=True)
class ShapeEstimate:
    """PCA of dipole positions (leading axes broadcast over sets of points).

    Attributes
    ----------
    centroid : ndarray, shape (..., 3)
        Mean position r̄ (m).
    eigenvalues : ndarray, shape (..., 3)
        λ1 ≥ λ2 ≥ λ3 of the covariance with N − 1 (m²).
    axes : ndarray, shape (..., 3, 3)
        ``axes[..., :, i]`` is the unit eigenvector u_{i+1}; u1 has a non-negative largest
        component (the sign of an eigenvector is arbitrary).
    span : ndarray, shape (...)
        max − min of the projections on u1 (m).
    line_scale : ndarray, shape (...)
        N / (N − 1) · span: the main scale read as a cylinder (m).
    spread_scale : ndarray, shape (...)
        √(12 λ1 N / (N + 1)): the cylinder's main scale from the spread along u1 (m).
    disc_diameter : ndarray, shape (...)
        :data:`DISC_FACTOR` × the in-plane diagonal: the main scale read as a disc (m).
    kind : ndarray of str, shape (...)
        "line" or "plane".
    main_scale : ndarray, shape (...)
        ``line_scale`` where the verdict is line, ``disc_diameter`` where it is plane (m).
    axis : ndarray, shape (..., 3)
        The target's axis as read: u1 for a line, u3 (the normal) for a plane.
    """

    centroid: np.ndarray
    eigenvalues: np.ndarray
    axes: np.ndarray
    span: np.ndarray
    line_scale: np.ndarray
    spread_scale: np.ndarray
    disc_diameter: np.ndarray
    kind: np.ndarray
    main_scale: np.ndarray
    axis: np.ndarray


def pca_shape(points):
    """Axis, main scale and line / plane verdict of N ≥ 2 dipole positions.

    Parameters
    ----------
    points : array_like, shape (..., N, 3)
        Dipole positions (m).

    Returns
    -------
    ShapeEstimate

    Examples
    --------
    >>> s = pca_shape([[0, 0, -1.125], [0, 0, -0.375], [0, 0, 0.375], [0, 0, 1.125]])
    >>> str(s.kind), float(s.main_scale), s.axis.tolist()
    ('line', 3.0, [0.0, 0.0, 1.0])
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim < 2 or pts.shape[-1] != 3 or pts.shape[-2] < 2:
        raise ValueError(f"points must have shape (..., N, 3) with N ≥ 2 positions in m; got {pts.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points must be finite (m)")
    n = pts.shape[-2]
    c = pts.mean(axis=-2)
    d = pts - c[..., None, :]  # (..., N, 3)
    C = np.einsum("...ni,...nj->...ij", d, d) / (n - 1)
    w, V = np.linalg.eigh(C)  # ascending
    w, V = w[..., ::-1], V[..., :, ::-1]
    w = np.clip(w, 0.0, None)
    # fix each eigenvector's sign: its largest-magnitude component positive
    big = np.take_along_axis(V, np.argmax(np.abs(V), axis=-2)[..., None, :], axis=-2)
    V = V * np.where(big < 0, -1.0, 1.0)
    u1, u3 = V[..., :, 0], V[..., :, 2]
    p = np.einsum("...ni,...i->...n", pts, u1)  # eq. (17)
    span = p.max(axis=-1) - p.min(axis=-1)
    line = n / (n - 1) * span  # eq. (18)
    inplane = np.einsum("...ni,...i->...n", d, u3)
    rms = np.sqrt(np.maximum(np.sum(d * d, axis=(-2, -1)) - np.sum(inplane**2, axis=-1), 0.0) / n)
    disc = DISC_FACTOR * 2.0 * rms
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(w[..., 0] > 0, w[..., 1] / np.where(w[..., 0] > 0, w[..., 0], 1.0), 0.0)
    plane = ratio >= PLANE_RATIO
    spread = np.sqrt(12.0 * w[..., 0] * n / (n + 1))
    return ShapeEstimate(centroid=c, eigenvalues=w, axes=V, span=span, line_scale=line,
                         spread_scale=spread, disc_diameter=disc, kind=np.where(plane, "plane", "line"),
                         main_scale=np.where(plane, disc, line),
                         axis=np.where(plane[..., None], u3, u1))


def axis_angle_deg(a, b):
    """Angle between two axes, sign-free (degrees, in [0, 90]).

    Parameters
    ----------
    a, b : array_like, shape (..., 3)
        Directions (need not be unit).

    Returns
    -------
    ndarray, shape (...)
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    # atan2(|a × b|, |a · b|): accurate at small angles, where arccos loses half the digits
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                 np.abs(np.sum(a * b, axis=-1))))
