"""The Cramér–Rao bound of seed 003's shape read, against the pass's closest approach.

The 15-state model (:mod:`core.shape.model`) at the target's own 4-dipole representation —
N dipoles at the centres of N equal segments of the axis (a cylinder of height H) or at the
corners of the square of diagonal D / :data:`core.shape.pca.DISC_FACTOR` (a disc of diameter
D), each with the moment M / N — seen by the one-sample gradiometer (σ per component, point
tensor) along a pass: Fisher information J = Σ_k H_kᵀ R⁻¹ H_k, covariance J⁻¹, and by the
delta method (central differences of the PCA read, step 1e-6 m) the standard deviations of

- the centroid (3-D RMS, m),
- the main scale in its two reads (m): the span read N/(N−1) · span along u1 (seed 003's eq.
  (18)) and the second-moment read √(12 λ1 N/(N+1)) (the spread along u1: :mod:`.pca`); for a
  plane both are the disc diameter,
- the axis angle (degrees: RMS angle of the perturbed u1, or of u3 for a plane).

This is the best any unbiased estimator of that model can do from noise alone: errors far above
it come from the model (4 dipoles for a continuum), not the noise. **Sizable**: the read that
sizes best has σ ≤ :data:`SIZABLE_FRACTION` of the true main scale (``ShapeBound.sizable``,
checked against the Monte-Carlo). Beside it, the *point-dipole* bound (one dipole of the total
moment at the centroid, 6 parameters) and the *rigid-line* bound (the dipoles on a rigid evenly
spaced line, 9 parameters). How the reads and bounds grow with the closest approach:
docs/shape.md, *Findings*.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.magnetic import magnetic_jacobian
from . import model as md
from .pca import DISC_FACTOR, pca_shape
from .targets import Pass, Target

__all__ = ["SIZABLE_FRACTION", "ShapeBound", "point_bound", "read_gradients", "representation", "shape_bound", "shape_bound_curve"]


def representation(target, n=md.N_DIPOLES):
    """The target's n-dipole state (3n + 3,): positions on its axis (line) or in its plane
    (disc, n = 4: a square), moment M / n each."""
    c, a = target.centroid, target.axis
    if target.kind == "line":
        pos = c + np.outer((np.arange(n) + 0.5) / n * target.height - target.height / 2, a)
    else:
        if n != 4:
            raise ValueError("a disc's representation is the 4-dipole square (n = 4)")
        half = target.main_scale / DISC_FACTOR / 2  # half-diagonal
        R = target.rotation
        pos = c + half * np.array([R[:, 0], R[:, 1], -R[:, 0], -R[:, 1]])
    return np.r_[pos.ravel(), target.total_moment / n]


#: Largest σ of the best read, as a fraction of the true main scale, for a pass to size the
#: target (module notes): 10 %, the issue's "size within 10 %".
SIZABLE_FRACTION = 0.10


@dataclass(frozen=True)
class ShapeBound:
    """Standard deviations of the bound (see the module notes). ``main_scale_m`` is the span
    read's σ, ``spread_main_scale_m`` the second-moment read's."""

    closest_approach_m: float
    centroid_m: float
    main_scale_m: float
    axis_deg: float
    dipole_position_m: float  # RMS over the dipoles' coordinates
    spread_main_scale_m: float = float("nan")
    target_main_scale_m: float = float("nan")
    rigid_centroid_m: float = float("nan")
    rigid_main_scale_m: float = float("nan")
    rigid_axis_deg: float = float("nan")
    point_position_m: float = float("nan")

    @property
    def best_main_scale_m(self):
        """σ of the read that sizes best (the smaller of the span's and the second moment's)."""
        return float(np.nanmin([self.main_scale_m, self.spread_main_scale_m]))

    @property
    def sizing(self):
        """Which read sizes best: "span" or "second moment"."""
        return "second moment" if self.spread_main_scale_m < self.main_scale_m else "span"

    @property
    def sizable(self):
        """Whether this pass can size the target (module notes)."""
        return bool(self.best_main_scale_m <= SIZABLE_FRACTION * self.target_main_scale_m)

    def to_dict(self):
        out = {k: float(v) for k, v in self.__dict__.items()}
        out.update(best_main_scale_m=self.best_main_scale_m, sizing=self.sizing,
                   sizable=self.sizable, sizable_fraction=SIZABLE_FRACTION)
        return out


def _read(x, n):
    s = pca_shape(x[: 3 * n].reshape(n, 3))
    spread = float(s.spread_scale) if str(s.kind) == "line" else float(s.main_scale)
    return s.centroid, float(s.main_scale), s.axis, spread


def shape_bound(target=None, track=None, noise=0.01, n=md.N_DIPOLES):
    """The bound for one pass; see the module notes. ``noise`` in nT/m."""
    target = Target() if target is None else target
    track = Pass() if track is None else track
    x = representation(target, n)
    mdl = md.DipoleModel(track.positions, n_dipoles=n)
    J = np.zeros((x.size, x.size))
    for k in range(track.samples):
        H = mdl.jacobian(x, k)
        J += H.T @ H / noise**2
    C = np.linalg.inv(J)
    dc, dL, da, dS = read_gradients(x, n)
    rigid = _rigid_line(target, mdl, track.samples, noise, n) if target.kind == "line" else {}
    return ShapeBound(
        **rigid,
        point_position_m=point_bound(target, track, noise),
        closest_approach_m=track.closest_approach(target.centroid),
        centroid_m=float(np.sqrt(np.trace(dc @ C @ dc.T))),
        main_scale_m=float(np.sqrt(dL @ C @ dL)),
        spread_main_scale_m=float(np.sqrt(dS @ C @ dS)),
        target_main_scale_m=float(target.main_scale),
        axis_deg=float(np.degrees(np.sqrt(np.trace(da @ C @ da.T)))),
        dipole_position_m=float(np.sqrt(np.trace(C[: 3 * n, : 3 * n]) / (3 * n))),
    )


def read_gradients(x, n=md.N_DIPOLES, h=1e-6):
    """Central differences (step ``h`` m) of the PCA read of state ``x`` (3n + 3,) with respect
    to it: centroid (3, P), span-read main scale (P,), axis (3, P) and second-moment main scale
    (P,); the moment columns are 0 (the read depends on the positions only). With a covariance
    C, σ² = g C gᵀ (the delta method)."""
    x = np.asarray(x, float)
    _, _, a0, _ = _read(x, n)
    dc, dL, da, dS = np.zeros((3, x.size)), np.zeros(x.size), np.zeros((3, x.size)), np.zeros(x.size)
    for i in range(3 * n):
        e = np.zeros(x.size)
        e[i] = h
        cp, Lp, ap, Sp = _read(x + e, n)
        cm, Lm, am, Sm = _read(x - e, n)
        ap, am = ap * np.sign(ap @ a0), am * np.sign(am @ a0)
        dc[:, i], dL[i], da[:, i] = (cp - cm) / (2 * h), (Lp - Lm) / (2 * h), (ap - am) / (2 * h)
        dS[i] = (Sp - Sm) / (2 * h)
    return dc, dL, da, dS


def point_bound(target=None, track=None, noise=0.01):
    """Position σ (3-D RMS, m) of a point dipole of the target's total moment at its centroid,
    position and moment free, from the one-sample gradiometer (5 components, σ ``noise`` nT/m,
    point tensor) along ``track`` (module notes)."""
    target = Target() if target is None else target
    track = Pass() if track is None else track
    _, H = magnetic_jacobian(md._states8(target.centroid, target.total_moment), track.positions,
                             sensor="G")  # (K, 5, 8): position, velocity, moment
    H = np.concatenate([H[..., :3], H[..., 5:]], axis=-1).reshape(-1, 6)
    C = np.linalg.inv(H.T @ H / noise**2)
    return float(np.sqrt(np.trace(C[:3, :3])))


def shape_bound_curve(cpas, target=None, track=None, noise=0.01):
    """:func:`shape_bound` for the pass moved to each closest approach in ``cpas`` (m)."""
    track = Pass() if track is None else track
    return [shape_bound(target, track.with_closest_approach(c), noise) for c in cpas]


def _rigid_line(target, mdl, samples, noise, n):
    """The rigid-line bound (module notes): parameters θ = [c (3), azimuth, elevation, L, m (3)]."""
    a = target.axis
    th0 = np.r_[target.centroid, np.arctan2(a[1], a[0]), np.arcsin(np.clip(a[2], -1, 1)),
                target.height, target.total_moment / n]

    def xfun(th):
        az, el = th[3], th[4]
        u = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        pos = th[:3] + np.outer((np.arange(n) + 0.5) / n * th[5] - th[5] / 2, u)
        return np.r_[pos.ravel(), th[6:]]

    h = 1e-6
    D = np.stack([(xfun(th0 + h * e) - xfun(th0 - h * e)) / (2 * h) for e in np.eye(th0.size)], -1)
    x = xfun(th0)
    J = np.zeros((th0.size, th0.size))
    for k in range(samples):
        H = mdl.jacobian(x, k) @ D
        J += H.T @ H / noise**2
    C = np.linalg.inv(J)
    ang = np.sqrt(C[3, 3] * np.cos(th0[4]) ** 2 + C[4, 4])  # RMS angle of the axis (rad)
    return {"rigid_centroid_m": float(np.sqrt(np.trace(C[:3, :3]))),
            "rigid_main_scale_m": float(np.sqrt(C[5, 5])), "rigid_axis_deg": float(np.degrees(ang))}
