"""A real sea: insulating air above, seawater, a conducting seabed below (spec §7).

Frame: z is depth, positive down; the sea surface is z = 0 and the seabed z = D. Seawater has
conductivity σ (the ``sigma`` of every public function), the seabed σb ≥ 0, the air none.

Image series (derived in ``docs/sea.md``)
-----------------------------------------
For a point current source at depth z0 in the water, the Hankel-domain potential is
``e^{−k|z−z0|} + a e^{−kz} + b e^{−k(D−z)}``. The insulating surface reflects with +1
(∂φ/∂z = 0 at z = 0); the seabed with η = (σ − σb)/(σ + σb) (continuity of φ and σ ∂φ/∂z at
z = D). Solving for a and b and expanding 1 / (1 − η e^{−2kD}) as a geometric series gives a
sum of terms ``e^{−k c}``, each the transform of ``1 / sqrt(ρ² + c²)``: a free-space source at
depth z' with c = |z − z'|. All the images are

    z'(ε, m) = ε·z0 + 2 m D,   weight η^|m|,   ε = ±1, m ∈ ℤ,

and c = |z − z'| holds for every receiver depth 0 ≤ z ≤ D, so the image positions do not depend
on the receiver. A dipole is the limit of two opposite sources, so its images are dipoles at
the same positions with the vertical moment multiplied by ε. (ε, m) = (+1, 0) is the source,
(−1, 0) its surface image; η = 0 (σb = σ) leaves these two: the half-space.

Truncation and tail
-------------------
Per target–station pair, the images are summed in groups G_m (the four images with |m| = m)
until the Euler–Maclaurin error estimate of closing the rest with an integral,
``|G_m − η G_{m−1}| / 24``, is at most ``tol / 2`` times the running total field. The rest,
Σ_{m > M} G_m, is then closed in closed form as the integral over a continuous image index t
from M + ½ to ∞ (the images become a line-like sum), times κ = (α/2)/sinh(α/2), α = −ln η,
which makes the midpoint rule exact for the geometric weight; the integral is an 8-node
Gauss–Legendre rule on t = M + ½ + b u/(1 − u), b = min(M + ½, 1/α). Every node is a virtual
image at a non-integer t, evaluated by the free-space kernel, so the Jacobian of the truncated
field, tail included, is exact by the chain rule. A conductive seabed (η < 0) gives an
alternating series: it is summed until |G_m| ≤ tol (1 − |η|) |E|, no tail.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from .fields import JIT, _local_jacobian

__all__ = ["DEFAULT_TOL", "Sea", "image_counts"]

#: Default truncation tolerance on the total field (relative).
DEFAULT_TOL = 1e-6
#: Image groups summed at most (a safeguard; reached only for η within ~1e-4 of −1).
MAX_GROUPS = 100_000



def _gauss_legendre01(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


# Gauss–Legendre nodes and weights on [0, 1] for the tail integral: 8 nodes in general, 4 where
# the tail is at most SMALL_TAIL of the field (4 nodes are then ample: see docs/sea.md).
_TAIL_U8, _TAIL_W8 = _gauss_legendre01(8)
_TAIL_U4, _TAIL_W4 = _gauss_legendre01(4)
SMALL_TAIL = 1e-3


@dataclass(frozen=True)
class Sea:
    """A sea of depth ``depth`` (m) over a seabed of conductivity ``seabed_sigma`` (S/m).

    Parameters
    ----------
    depth : float
        Water depth D (m), finite, > 0. The surface is z = 0, the seabed z = D (z down).
    seabed_sigma : float
        Seabed conductivity σb (S/m), finite, ≥ 0 (0: an insulating seabed).
    tol : float
        Relative truncation tolerance of the image series on the total field, in
        [1e-14, 1e-6] (default 1e-6).

    Examples
    --------
    >>> import core
    >>> sea = core.Sea(8.4, 0.4)
    >>> round(sea.eta(4.0), 4)
    0.8182
    """

    depth: float
    seabed_sigma: float
    tol: float = DEFAULT_TOL

    def __post_init__(self):
        for name, value, ok, accepted in (
            ("depth", self.depth, lambda v: v > 0.0, "a finite number > 0 (m)"),
            ("seabed_sigma", self.seabed_sigma, lambda v: v >= 0.0, "a finite number ≥ 0 (S/m)"),
            ("tol", self.tol, lambda v: 1e-14 <= v <= 1e-6, "a number in [1e-14, 1e-6]"),
        ):
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise ValueError(f"Sea {name} must be {accepted}; got {value!r}") from None
            if not (math.isfinite(v) and ok(v)):
                raise ValueError(f"Sea {name} must be {accepted}; got {value!r}")
            object.__setattr__(self, name, v)

    @classmethod
    def from_resistivity(cls, depth, seabed_resistivity, tol=DEFAULT_TOL):
        """A sea from the seabed resistivity ρb (Ω·m, > 0; ``inf`` for an insulating seabed)."""
        try:
            rho = float(seabed_resistivity)
        except (TypeError, ValueError):
            rho = float("nan")
        if not rho > 0.0:
            raise ValueError(f"seabed_resistivity must be a number > 0 (Ω·m); got {seabed_resistivity!r}")
        return cls(depth, 0.0 if math.isinf(rho) else 1.0 / rho, tol)

    @property
    def seabed_resistivity(self):
        """ρb = 1/σb (Ω·m); inf for an insulating seabed."""
        return math.inf if self.seabed_sigma == 0.0 else 1.0 / self.seabed_sigma

    def eta(self, sigma):
        """Seabed reflection coefficient η = (σ − σb)/(σ + σb) ∈ (−1, 1] for water σ (S/m)."""
        return (sigma - self.seabed_sigma) / (sigma + self.seabed_sigma)


#: The kernels' medium of the whole space (``sea=None``): depth 0 switches the images off.
WHOLE_SPACE = np.zeros(3)


def medium(sea, sigma):
    """Kernel form of a sea: float64 ``[D, η, tol]``; :data:`WHOLE_SPACE` for ``sea=None``."""
    if sea is None:
        return WHOLE_SPACE
    if not isinstance(sea, Sea):
        raise ValueError(f"sea must be None (whole space) or a core.Sea; got {type(sea).__name__}")
    return np.array([sea.depth, sea.eta(sigma), sea.tol])


def check_column(sea, states, stations, model):
    """With a sea, every target (P, 7) and station (S, 3) must be in the water column 0 ≤ z ≤ D,
    and the model must be "exact"."""
    if sea is None:
        return
    if model != "exact":
        raise ValueError(f"model {model!r} has no layered-sea form: the paper's printed formulas "
                         "are not a dipole field, so they have no images; use model='exact' with sea")
    for name, z in (("target depth z", states[:, 2]), ("station depth", stations[:, 2])):
        bad = (z < 0.0) | (z > sea.depth)
        if np.any(bad):
            raise ValueError(f"{name} {float(z[bad][0])!r} m is outside the water column: with "
                             f"sea=Sea(depth={sea.depth!r}) it must lie in [0, {sea.depth!r}] m "
                             "(z is depth, positive down; surface 0, seabed D)")


@nb.njit(inline="always", **JIT)
def _add(acc, rows, eps):
    """acc + rows of one image, chain rule through its mirrored position and moment: the image
    depth is ε·z + const and its vertical moment ε·Pv, so ∂/∂z and ∂/∂Pv take a factor ε."""
    out0 = (acc[0][0] + rows[0][0], acc[0][1] + rows[0][1], acc[0][2] + rows[0][2],
            acc[0][3] + eps * rows[0][3], acc[0][4] + rows[0][4], acc[0][5] + rows[0][5],
            acc[0][6] + rows[0][6], acc[0][7] + eps * rows[0][7])
    out1 = (acc[1][0] + rows[1][0], acc[1][1] + rows[1][1], acc[1][2] + rows[1][2],
            acc[1][3] + eps * rows[1][3], acc[1][4] + rows[1][4], acc[1][5] + rows[1][5],
            acc[1][6] + rows[1][6], acc[1][7] + eps * rows[1][7])
    out2 = (acc[2][0] + rows[2][0], acc[2][1] + rows[2][1], acc[2][2] + rows[2][2],
            acc[2][3] + eps * rows[2][3], acc[2][4] + rows[2][4], acc[2][5] + rows[2][5],
            acc[2][6] + rows[2][6], acc[2][7] + eps * rows[2][7])
    return (out0, out1, out2)


@nb.njit(inline="always", **JIT)
def _group(acc, rx, ry, z, sz, vx, vy, ph, pv, kw, shift):
    """acc + the four images at index ±t (shift = 2 t D), each weighted by kw = κ_water · w:
    ε = +1 at z ± shift, ε = −1 at −z ± shift."""
    acc = _add(acc, _local_jacobian(rx, ry, z + shift - sz, vx, vy, ph, pv, kw, 0), 1.0)
    acc = _add(acc, _local_jacobian(rx, ry, z - shift - sz, vx, vy, ph, pv, kw, 0), 1.0)
    acc = _add(acc, _local_jacobian(rx, ry, -z + shift - sz, vx, vy, ph, -pv, kw, 0), -1.0)
    return _add(acc, _local_jacobian(rx, ry, -z - shift - sz, vx, vy, ph, -pv, kw, 0), -1.0)


@nb.njit(**JIT)
def layered_rows(rx, ry, z, sz, vx, vy, ph, pv, kappa, depth, eta, tol):
    """Field and ∂E/∂X of the target at depth z seen by a station at depth sz, horizontal
    offset (rx, ry) = target − station, in the layered sea (D = ``depth``, η, tol): the same
    three rows as :func:`core.fields._local_jacobian`, and the number of free-space images
    evaluated. Assumes valid input (both in the water column, not on the station)."""
    # 1. m = 0: the source and its surface image
    acc = _local_jacobian(rx, ry, z - sz, vx, vy, ph, pv, kappa, 0)
    acc = _add(acc, _local_jacobian(rx, ry, -z - sz, vx, vy, ph, -pv, kappa, 0), -1.0)
    n_img = 2
    if eta == 0.0:
        return acc, n_img
    zero = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    # 2. groups |m| = 1, 2, …, until the tail can be closed (or, η < 0, neglected)
    w = 1.0
    p0 = p1 = p2 = 0.0
    m = 0
    while m < MAX_GROUPS:
        m += 1
        w *= eta
        g = _group((zero, zero, zero), rx, ry, z, sz, vx, vy, ph, pv, kappa * w, 2.0 * m * depth)
        acc = _add(acc, g, 1.0)
        n_img += 4
        g0, g1, g2 = g[0][0], g[1][0], g[2][0]
        total = math.sqrt(acc[0][0] ** 2 + acc[1][0] ** 2 + acc[2][0] ** 2)
        if eta < 0.0:
            if math.sqrt(g0 * g0 + g1 * g1 + g2 * g2) <= tol * (1.0 + eta) * total:
                return acc, n_img
        d0, d1, d2 = g0 - eta * p0, g1 - eta * p1, g2 - eta * p2
        p0, p1, p2 = g0, g1, g2  # G_m, for the next step and the tail's size
        if eta > 0.0 and m >= 2 and math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) <= 12.0 * tol * total:
            break
    if eta < 0.0:
        return acc, n_img
    # geometric estimate of the tail's share of the field decides the rule's size
    small = eta < 1.0 and math.sqrt(p0 * p0 + p1 * p1 + p2 * p2) * eta <= SMALL_TAIL * (1.0 - eta) * total
    nodes, weights = (_TAIL_U4, _TAIL_W4) if small else (_TAIL_U8, _TAIL_W8)
    # 3. the tail Σ_{m > M} G_m as κ ∫_{M+½}^∞ G(t) dt, G(t) = η^t (images at index t)
    a = m + 0.5
    alpha = -math.log(eta)
    b = min(a, 1.0 / alpha) if alpha > 0.0 else a
    kap = 0.5 * alpha / math.sinh(0.5 * alpha) if alpha > 0.0 else 1.0
    for j in range(nodes.shape[0]):
        u = nodes[j]
        t = a + b * u / (1.0 - u)
        wt = kap * weights[j] * b / ((1.0 - u) * (1.0 - u)) * math.exp(-alpha * t)
        acc = _group(acc, rx, ry, z, sz, vx, vy, ph, pv, kappa * wt, 2.0 * t * depth)
    return acc, n_img + 4 * nodes.shape[0]


@nb.njit(inline="always", **JIT)
def station_rows(rx, ry, z, sz, vx, vy, ph, pv, kappa, model, medium):
    """The one measurement model of every kernel: the three rows (E_i, ∂E_i/∂X) of a target at
    depth z and a station at depth sz, horizontal offset (rx, ry). ``medium`` = [D, η, tol];
    D = 0 is the whole space, the single direct image (exactly :func:`_local_jacobian`)."""
    if medium[0] > 0.0:
        return layered_rows(rx, ry, z, sz, vx, vy, ph, pv, kappa, medium[0], medium[1], medium[2])[0]
    return _local_jacobian(rx, ry, z - sz, vx, vy, ph, pv, kappa, model)


@nb.njit(parallel=True, nogil=True, **JIT)
def _count_kernel(states, stations, depth, eta, tol, out):
    for p in nb.prange(states.shape[0]):
        x = states[p]
        for s in range(stations.shape[0]):
            out[p, s] = layered_rows(x[0] - stations[s, 0], x[1] - stations[s, 1], x[2], stations[s, 2],
                                     x[3], x[4], x[5], x[6], 1.0, depth, eta, tol)[1]


def image_counts(states, stations, sea, *, sigma=4.0):
    """Number of free-space images (tail nodes included) the series uses per target and station.

    Returns
    -------
    ndarray of int, shape (..., S)
    """
    from . import validation

    states, stations, lead = validation.states_and_stations(states, stations)
    sigma = validation.positive("sigma", sigma, "S/m")
    if not isinstance(sea, Sea):
        raise ValueError(f"sea must be a core.Sea; got {type(sea).__name__}")
    check_column(sea, states, stations, "exact")
    validation.no_target_on_station(states, stations)
    out = np.empty((states.shape[0], stations.shape[0]), dtype=np.int64)
    _count_kernel(states, stations, sea.depth, sea.eta(sigma), sea.tol, out)
    return out.reshape(lead + (stations.shape[0],))
