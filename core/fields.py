"""Electric field of a moving current dipole at a sensor station, and its Jacobian.

Both field models share one form. With ``r = target − station`` (m), ``D = |r|``, the
moment features ``f = (Ph cos θ, Ph sin θ, Pv, Ph)`` (A·m) and ``θ = atan2(vy, vx)``,

    E_i = K · Σ_k A_ik(r) f_k / D⁵,    K = 1 / (4 π σ),

where every entry ``A_ik`` is a quadratic form in ``r``: a sum of terms ``coef · r_m r_n`` or
``coef · D²``. A field model is therefore nothing but a table of such terms
(:data:`MODEL_TERMS`), and one compiled kernel differentiates any table exactly.

- ``exact``: the point current dipole in a homogeneous conductor,
  ``A = 3 r rᵀ − D² I`` on the first three features (spec §2).
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
from .validation import STATE_NAMES

__all__ = ["MODELS", "STATE_NAMES", "MODEL_TERMS", "dipole_field", "field_jacobian"]

#: State units, in the same order.
STATE_UNITS = ("m", "m", "m", "m/s", "m/s", "A·m", "A·m")

# A term is (i, k, m, n, coef): E_i gets coef·f_k·r_m·r_n, or coef·f_k·D² when n == -1.
_D2 = -1
_EXACT_TERMS = (
    # 3 r_i r_k f_k for i, k in x, y, z
    *[(i, k, i, k, 3.0) for i in range(3) for k in range(3)],
    # −D² f_i
    *[(i, i, 0, _D2, -1.0) for i in range(3)],
)
_PAPER_TERMS = (
    # eq. (10): Ex = Ph cosθ (3a² − D²) − Ph sinθ 3ab + Pv 3ac
    (0, 0, 0, 0, 3.0), (0, 0, 0, _D2, -1.0), (0, 1, 0, 1, -3.0), (0, 2, 0, 2, 3.0),
    # eq. (11): Ey = Ph sinθ (3a² − D²) + Ph cosθ 3ab + Pv 3bc
    (1, 1, 0, 0, 3.0), (1, 1, 0, _D2, -1.0), (1, 0, 0, 1, 3.0), (1, 2, 1, 2, 3.0),
    # eq. (12): Ez = Ph 3ac + Pv (3c² − D²)
    (2, 3, 0, 2, 3.0), (2, 2, 2, 2, 3.0), (2, 2, 0, _D2, -1.0),
)


def _table(terms):
    idx = np.array([t[:4] for t in terms], dtype=np.int64)  # (nterms, 4): i, k, m, n
    coef = np.array([t[4] for t in terms], dtype=np.float64)  # (nterms,)
    return idx, coef


#: Field models: name -> (term indices (nterms, 4), coefficients (nterms,)).
MODEL_TERMS = {"exact": _table(_EXACT_TERMS), "paper": _table(_PAPER_TERMS)}
#: Accepted field-model names.
MODELS = tuple(MODEL_TERMS)


@nb.njit(cache=True, fastmath=False, inline="always")
def _local_jacobian(rx, ry, rz, vx, vy, ph, pv, kappa, t_idx, t_coef, nbuf, dndr, dndf, e, jac):
    """Field ``e`` (3,) and ∂E/∂X ``jac`` (3, 7) at one target–station offset ``r``.

    ``nbuf`` (3,), ``dndr`` (3, 3) and ``dndf`` (3, 4) are scratch. Assumes D > 0, speed > 0.
    """
    speed = math.sqrt(vx * vx + vy * vy)
    c = vx / speed
    s = vy / speed
    f0 = ph * c
    f1 = ph * s
    d2 = rx * rx + ry * ry + rz * rz
    for i in range(3):
        nbuf[i] = 0.0
        for j in range(3):
            dndr[i, j] = 0.0
        for k in range(4):
            dndf[i, k] = 0.0
    # 1. Numerator N = A(r) f and its exact partials, term by term.
    for t in range(t_idx.shape[0]):
        i = t_idx[t, 0]
        k = t_idx[t, 1]
        m = t_idx[t, 2]
        n = t_idx[t, 3]
        cf = t_coef[t]
        fk = f0 if k == 0 else (f1 if k == 1 else (pv if k == 2 else ph))
        rm = rx if m == 0 else (ry if m == 1 else rz)
        if n < 0:  # coef · f_k · D²
            nbuf[i] += cf * fk * d2
            dndf[i, k] += cf * d2
            dndr[i, 0] += 2.0 * cf * fk * rx
            dndr[i, 1] += 2.0 * cf * fk * ry
            dndr[i, 2] += 2.0 * cf * fk * rz
        else:  # coef · f_k · r_m r_n
            rn = rx if n == 0 else (ry if n == 1 else rz)
            nbuf[i] += cf * fk * rm * rn
            dndf[i, k] += cf * rm * rn
            dndr[i, m] += cf * fk * rn
            dndr[i, n] += cf * fk * rm
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


@nb.njit(cache=True, parallel=True)
def _field_and_jacobian_kernel(states, stations, kappa, t_idx, t_coef, e_out, j_out):
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
                    x[3], x[4], x[5], x[6], kappa, t_idx, t_coef,
                    nbuf, dndr, dndf, e_out[p, s], j_out[p, s],
                )


def _field_and_jacobian(states, stations, sigma, model):
    """Validated front end: returns E (..., S, 3) and ∂E/∂X (..., S, 3, 7)."""
    states, stations, lead = validation.states_and_stations(states, stations)
    sigma = validation.positive("sigma", sigma, "S/m")
    idx, coef = validation.model_terms(model, MODEL_TERMS)
    validation.no_target_on_station(states, stations)
    n_s = stations.shape[0]
    e = np.empty((states.shape[0], n_s, 3))
    jac = np.empty((states.shape[0], n_s, 3, 7))
    _field_and_jacobian_kernel(states, stations, 1.0 / (4.0 * np.pi * sigma), idx, coef, e, jac)
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
