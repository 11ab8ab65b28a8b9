"""Electric field of a moving current dipole at a sensor station, and its Jacobian.

Both field models share one form. With ``r = (a, b, c) = target − station`` (m), ``D = |r|``,
the moment features ``f = (Ph cos θ, Ph sin θ, Pv, Ph)`` (A·m) and ``θ = atan2(vy, vx)``,

    E = K · N(r, f) / D⁵,    K = 1 / (4 π σ),

with N quadratic in r and linear in f. One kernel applies the quotient rule and the heading
chain to either model's N and its hand-derived partials.

- ``exact``: the point current dipole in a homogeneous conductor, N = 3 (p·r) r − p D² with
  p = f[:3] (spec §2).
- ``paper``: eqs. (10)–(12) of the source paper *as printed*. Compared with ``exact`` its
  E_x has ``−3ab`` where ``+3ab`` belongs, its E_y uses ``3a² − D²`` where ``3b² − D²``
  belongs, and its E_z uses the bare ``Ph`` (feature 3) instead of the heading-resolved
  moment. Kept only so that the paper's figures can be reproduced.

The kernels here assume valid input (finite, ``D > 0``, speed > 0); validation happens at the
public boundary in :mod:`core.validation`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from . import validation

__all__ = ["MODELS", "STATE_UNITS", "dipole_field", "field_jacobian"]

#: Floating-point licence of the compiled kernels: LLVM may contract to FMA and reassociate
#: sums (measured ~2x faster, results within 1e-15 relative); NaN and inf keep their IEEE meaning.
FASTMATH = {"contract", "reassoc", "nsz", "arcp"}

#: State units, in the same order.
STATE_UNITS = ("m", "m", "m", "m/s", "m/s", "A·m", "A·m")

#: Accepted field-model names; the index is the kernels' model code.
MODELS = ("exact", "paper")


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _numerator_exact(a, b, c, f, nbuf, dndr, dndf):
    """Exact dipole: N = 3 (p·r) r − p D², p = f[:3]. Hand-derived partials."""
    d2 = a * a + b * b + c * c
    r = (a, b, c)
    pr = f[0] * a + f[1] * b + f[2] * c
    for i in range(3):
        nbuf[i] = 3.0 * pr * r[i] - f[i] * d2
        for j in range(3):
            # dN_i/dr_j = 3 p_j r_i + 3 (p·r) δ_ij − 2 p_i r_j
            dndr[i, j] = 3.0 * f[j] * r[i] - 2.0 * f[i] * r[j]
            # dN_i/dp_j = 3 r_i r_j − δ_ij D²
            dndf[i, j] = 3.0 * r[i] * r[j]
        dndr[i, i] += 3.0 * pr
        dndf[i, i] -= d2
        dndf[i, 3] = 0.0  # the bare Ph feature does not enter the exact field


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _numerator_paper(a, b, c, f, nbuf, dndr, dndf):
    """The paper's eqs. (10)–(12) as printed, with (a, b, c) = (x, y, z − h) of the target
    relative to the station; f = (Ph cos θ, Ph sin θ, Pv, Ph)."""
    d2 = a * a + b * b + c * c
    q = 3.0 * a * a - d2  # the printed 3x² − D², used in both Ex and Ey
    # eq. (10): Ex = Ph cosθ (3a² − D²) − Ph sinθ 3ab + Pv 3ac
    nbuf[0] = f[0] * q - 3.0 * f[1] * a * b + 3.0 * f[2] * a * c
    dndr[0, 0] = 4.0 * f[0] * a - 3.0 * f[1] * b + 3.0 * f[2] * c
    dndr[0, 1] = -2.0 * f[0] * b - 3.0 * f[1] * a
    dndr[0, 2] = -2.0 * f[0] * c + 3.0 * f[2] * a
    dndf[0, 0], dndf[0, 1], dndf[0, 2], dndf[0, 3] = q, -3.0 * a * b, 3.0 * a * c, 0.0
    # eq. (11): Ey = Ph sinθ (3a² − D²) + Ph cosθ 3ab + Pv 3bc
    nbuf[1] = f[1] * q + 3.0 * f[0] * a * b + 3.0 * f[2] * b * c
    dndr[1, 0] = 4.0 * f[1] * a + 3.0 * f[0] * b
    dndr[1, 1] = -2.0 * f[1] * b + 3.0 * f[0] * a + 3.0 * f[2] * c
    dndr[1, 2] = -2.0 * f[1] * c + 3.0 * f[2] * b
    dndf[1, 0], dndf[1, 1], dndf[1, 2], dndf[1, 3] = 3.0 * a * b, q, 3.0 * b * c, 0.0
    # eq. (12): Ez = Ph 3ac + Pv (3c² − D²)   (no heading: the bare Ph, feature 3)
    nbuf[2] = 3.0 * f[3] * a * c + f[2] * (3.0 * c * c - d2)
    dndr[2, 0] = 3.0 * f[3] * c - 2.0 * f[2] * a
    dndr[2, 1] = -2.0 * f[2] * b
    dndr[2, 2] = 3.0 * f[3] * a + 4.0 * f[2] * c
    dndf[2, 0], dndf[2, 1], dndf[2, 2], dndf[2, 3] = 0.0, 0.0, 3.0 * c * c - d2, 3.0 * a * c


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _local_jacobian(rx, ry, rz, vx, vy, ph, pv, kappa, model, nbuf, dndr, dndf, e, jac):
    """Field ``e`` (3,) and ∂E/∂X ``jac`` (3, 7) at one target–station offset ``r``.

    ``model`` is an index into :data:`MODELS`; ``nbuf`` (3,), ``dndr`` (3, 3) and ``dndf``
    (3, 4) are scratch. Assumes D > 0, speed > 0.
    """
    speed = math.sqrt(vx * vx + vy * vy)
    c = vx / speed
    s = vy / speed
    f0 = ph * c
    f1 = ph * s
    d2 = rx * rx + ry * ry + rz * rz
    # 1. Numerator N = D⁵ E / K and its partials in r and in the features f.
    if model == 0:
        _numerator_exact(rx, ry, rz, (f0, f1, pv, ph), nbuf, dndr, dndf)
    else:
        _numerator_paper(rx, ry, rz, (f0, f1, pv, ph), nbuf, dndr, dndf)
    # 2. E = K N / D⁵ and the quotient rule: ∂E/∂r = K (∂N/∂r − 5 N rᵀ / D²) / D⁵.
    inv5 = kappa / (d2 * d2 * math.sqrt(d2))
    for i in range(3):
        ei = nbuf[i] * inv5
        e[i] = ei
        five_e = 5.0 * ei / d2
        jac[i, 0] = dndr[i, 0] * inv5 - five_e * rx  # dE/dx  (r = target − station)
        jac[i, 1] = dndr[i, 1] * inv5 - five_e * ry  # dE/dy
        jac[i, 2] = dndr[i, 2] * inv5 - five_e * rz  # dE/dz
        # 3. Moments: f = (Ph c, Ph s, Pv, Ph); heading θ = atan2(vy, vx).
        de_df0 = dndf[i, 0] * inv5
        de_df1 = dndf[i, 1] * inv5
        de_dtheta = -de_df0 * f1 + de_df1 * f0  # dE/dθ = dE/df0·(−Ph s) + dE/df1·(Ph c)
        jac[i, 3] = -de_dtheta * s / speed  # dE/dvx, dθ/dvx = −sin θ / |v|
        jac[i, 4] = de_dtheta * c / speed  # dE/dvy, dθ/dvy = cos θ / |v|
        jac[i, 5] = de_df0 * c + de_df1 * s + dndf[i, 3] * inv5  # dE/dPh
        jac[i, 6] = dndf[i, 2] * inv5  # dE/dPv


@nb.njit(cache=True, parallel=True, nogil=True)
def _field_and_jacobian_kernel(states, stations, kappa, model, e_out, j_out):
    # states (P, 7), stations (S, 3) -> e_out (P, S, 3), j_out (P, S, 3, 7)
    npts = states.shape[0]
    nblock = (npts + 255) // 256
    for b in nb.prange(nblock):
        nbuf = np.empty(3)
        dndr = np.empty((3, 3))
        dndf = np.empty((3, 4))
        for p in range(b * 256, min(npts, (b + 1) * 256)):
            x = states[p]
            for s in range(stations.shape[0]):
                _local_jacobian(
                    x[0] - stations[s, 0], x[1] - stations[s, 1], x[2] - stations[s, 2],
                    x[3], x[4], x[5], x[6], kappa, model,
                    nbuf, dndr, dndf, e_out[p, s], j_out[p, s],
                )


def _field_and_jacobian(states, stations, sigma, model):
    """Validated front end: returns E (..., S, 3) and ∂E/∂X (..., S, 3, 7)."""
    states, stations, lead = validation.states_and_stations(states, stations)
    sigma = validation.positive("sigma", sigma, "S/m")
    code = validation.model_code(model, MODELS)
    validation.no_target_on_station(states, stations)
    n_s = stations.shape[0]
    e = np.empty((states.shape[0], n_s, 3))
    jac = np.empty((states.shape[0], n_s, 3, 7))
    _field_and_jacobian_kernel(states, stations, 1.0 / (4.0 * np.pi * sigma), code, e, jac)
    return e.reshape(lead + (n_s, 3)), jac.reshape(lead + (n_s, 3, 7))


def dipole_field(states, stations, *, sigma=4.0, model="exact"):
    """Static electric field of the target dipole at each station.

    Parameters
    ----------
    states : array_like, shape (..., 7)
        ``[x, y, z, vx, vy, Ph, Pv]``: target position (m), horizontal velocity (m/s; the
        horizontal moment points along the heading θ = atan2(vy, vx), so speed must be > 0),
        horizontal and vertical dipole moments (A·m).
    stations : array_like, shape (S, 3)
        Station positions (m), S ≥ 1.
    sigma : float
        Sea conductivity (S/m), > 0.
    model : {"exact", "paper"}
        ``"exact"``: point current dipole in a homogeneous conductor. ``"paper"``: the source
        paper's eqs. (10)–(12) as printed (not the field of any dipole; see module notes).

    Returns
    -------
    E : ndarray, shape (..., S, 3)
        ``(Ex, Ey, Ez)`` in V/m at every station.

    Raises
    ------
    ValueError
        Wrong shapes, non-finite values, zero speed, σ ≤ 0, unknown model, or a target at a
        station (D = 0, where the field is singular).

    Examples
    --------
    On the dipole axis the exact field is ``2 p / (4 π σ D³)``:

    >>> import numpy as np, core
    >>> E = core.dipole_field([0, 0, 0, 1, 0, 100, 0], [[10, 0, 0]], sigma=1.0)
    >>> bool(np.isclose(E[0, 0], 2 * 100 / (4 * np.pi * 1000)))
    True
    """
    return _field_and_jacobian(states, stations, sigma, model)[0]


def field_jacobian(states, stations, *, sigma=4.0, model="exact"):
    """Exact Jacobian ∂E/∂X of the station fields with respect to the 7 states.

    Parameters are those of :func:`dipole_field`.

    Returns
    -------
    J : ndarray, shape (..., S, 3, 7)
        ``J[..., s, i, j] = ∂E_i(station s) / ∂X_j`` in (V/m) per state unit
        (m, m/s, A·m). Analytic: the quotient rule on the term table plus the heading chain
        ``∂θ/∂vx = −sin θ/|v|, ∂θ/∂vy = cos θ/|v|``.

    Examples
    --------
    >>> import core
    >>> core.field_jacobian([30, 40, 120, 2, 2, 100, 20], [[0, 0, 100]]).shape
    (1, 3, 7)
    """
    return _field_and_jacobian(states, stations, sigma, model)[1]
