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


#: Compile options of every kernel. ``error_model="numpy"``: a float division by zero gives inf
#: instead of raising, which keeps loops branch-free so that LLVM can vectorise them.
JIT = dict(cache=True, fastmath=FASTMATH, error_model="numpy")


@nb.njit(inline="always", **JIT)
def _numerator_exact(a, b, c, f0, f1, f2, f3):
    """Exact dipole: N = 3 (p·r) r − p D², p = (f0, f1, f2). Hand-derived partials.

    Returns (N (3), ∂N/∂r (3 × 3, row-major), ∂N/∂f (3 × 4, row-major)) as one flat tuple:
    ∂N_i/∂r_j = 3 p_j r_i − 2 p_i r_j + 3 (p·r) δ_ij and ∂N_i/∂p_j = 3 r_i r_j − δ_ij D²; the
    bare Ph feature f3 does not enter the exact field.
    """
    d2 = a * a + b * b + c * c
    t = 3.0 * (f0 * a + f1 * b + f2 * c)  # 3 (p·r)
    return (t * a - f0 * d2, t * b - f1 * d2, t * c - f2 * d2,
            f0 * a + t, 3.0 * f1 * a - 2.0 * f0 * b, 3.0 * f2 * a - 2.0 * f0 * c,
            3.0 * f0 * b - 2.0 * f1 * a, f1 * b + t, 3.0 * f2 * b - 2.0 * f1 * c,
            3.0 * f0 * c - 2.0 * f2 * a, 3.0 * f1 * c - 2.0 * f2 * b, f2 * c + t,
            3.0 * a * a - d2, 3.0 * a * b, 3.0 * a * c, 0.0,
            3.0 * a * b, 3.0 * b * b - d2, 3.0 * b * c, 0.0,
            3.0 * a * c, 3.0 * b * c, 3.0 * c * c - d2, 0.0)


@nb.njit(inline="always", **JIT)
def _numerator_paper(a, b, c, f0, f1, f2, f3):
    """The paper's eqs. (10)–(12) as printed, with (a, b, c) = (x, y, z − h) of the target
    relative to the station; f = (Ph cos θ, Ph sin θ, Pv, Ph). Same flat tuple as
    :func:`_numerator_exact`."""
    d2 = a * a + b * b + c * c
    q = 3.0 * a * a - d2  # the printed 3x² − D², used in both Ex and Ey
    return (
        # eq. (10): Ex = Ph cosθ (3a² − D²) − Ph sinθ 3ab + Pv 3ac
        # eq. (11): Ey = Ph sinθ (3a² − D²) + Ph cosθ 3ab + Pv 3bc
        # eq. (12): Ez = Ph 3ac + Pv (3c² − D²)   (no heading: the bare Ph, feature 3)
        f0 * q - 3.0 * f1 * a * b + 3.0 * f2 * a * c,
        f1 * q + 3.0 * f0 * a * b + 3.0 * f2 * b * c,
        3.0 * f3 * a * c + f2 * (3.0 * c * c - d2),
        4.0 * f0 * a - 3.0 * f1 * b + 3.0 * f2 * c, -2.0 * f0 * b - 3.0 * f1 * a, -2.0 * f0 * c + 3.0 * f2 * a,
        4.0 * f1 * a + 3.0 * f0 * b, -2.0 * f1 * b + 3.0 * f0 * a + 3.0 * f2 * c, -2.0 * f1 * c + 3.0 * f2 * b,
        3.0 * f3 * c - 2.0 * f2 * a, -2.0 * f2 * b, 3.0 * f3 * a + 4.0 * f2 * c,
        q, -3.0 * a * b, 3.0 * a * c, 0.0,
        3.0 * a * b, q, 3.0 * b * c, 0.0,
        0.0, 0.0, 3.0 * c * c - d2, 3.0 * a * c,
    )


@nb.njit(inline="always", **JIT)
def _jacobian_row(n, r0, r1, r2, q0, q1, q2, q3, a, b, c, d2, inv5, f0, f1, cos, sin, inv_speed):
    """One field component from its numerator ``n`` and partials: (E_i, ∂E_i/∂X (7)).

    Quotient rule ∂E/∂r = K (∂N/∂r − 5 N r / D²) / D⁵ (``inv5`` = K / D⁵); moments through
    f = (Ph cos θ, Ph sin θ, Pv, Ph) and the heading θ = atan2(vy, vx), with
    ∂θ/∂vx = −sin θ / |v| and ∂θ/∂vy = cos θ / |v|.
    """
    e = n * inv5
    five = 5.0 * e / d2
    df0 = q0 * inv5
    df1 = q1 * inv5
    de_dtheta = (df1 * f0 - df0 * f1) * inv_speed  # (dE/df0·(−Ph s) + dE/df1·(Ph c)) / |v|
    return (e, r0 * inv5 - five * a, r1 * inv5 - five * b, r2 * inv5 - five * c,
            -de_dtheta * sin, de_dtheta * cos, df0 * cos + df1 * sin + q3 * inv5, q2 * inv5)


@nb.njit(inline="always", **JIT)
def _local_jacobian(rx, ry, rz, vx, vy, ph, pv, kappa, model):
    """Field and ∂E/∂X at one target–station offset ``r`` (target − station), as three rows
    (Ex, Ey, Ez), each ``(E_i, ∂E_i/∂x, ∂E_i/∂y, ∂E_i/∂z, ∂E_i/∂vx, ∂E_i/∂vy, ∂E_i/∂Ph,
    ∂E_i/∂Pv)``. Scalars in, a tuple out: no memory, so loops over points vectorise.

    ``model`` is an index into :data:`MODELS`. Assumes D > 0, speed > 0.
    """
    inv_speed = 1.0 / math.sqrt(vx * vx + vy * vy)
    cos = vx * inv_speed
    sin = vy * inv_speed
    f0 = ph * cos
    f1 = ph * sin
    if model == 0:
        t = _numerator_exact(rx, ry, rz, f0, f1, pv, ph)
    else:
        t = _numerator_paper(rx, ry, rz, f0, f1, pv, ph)
    d2 = rx * rx + ry * ry + rz * rz
    inv5 = kappa / (d2 * d2 * math.sqrt(d2))
    return (
        _jacobian_row(t[0], t[3], t[4], t[5], t[12], t[13], t[14], t[15],
                      rx, ry, rz, d2, inv5, f0, f1, cos, sin, inv_speed),
        _jacobian_row(t[1], t[6], t[7], t[8], t[16], t[17], t[18], t[19],
                      rx, ry, rz, d2, inv5, f0, f1, cos, sin, inv_speed),
        _jacobian_row(t[2], t[9], t[10], t[11], t[20], t[21], t[22], t[23],
                      rx, ry, rz, d2, inv5, f0, f1, cos, sin, inv_speed),
    )


@nb.njit(inline="always", **JIT)
def _store_rows(rows, e, jac):
    """Write :func:`_local_jacobian`'s rows into ``e`` (3,) and ``jac`` (3, 7)."""
    for i in range(3):
        row = rows[i]
        e[i] = row[0]
        jac[i, 0], jac[i, 1], jac[i, 2], jac[i, 3] = row[1], row[2], row[3], row[4]
        jac[i, 4], jac[i, 5], jac[i, 6] = row[5], row[6], row[7]


def _field_and_jacobian(states, stations, sigma, model, sea):
    """Validated front end: returns E (..., S, 3) and ∂E/∂X (..., S, 3, 7)."""
    from . import kernels  # both import this module's free-space kernel
    from . import sea as sea_module

    states, stations, lead = validation.states_and_stations(states, stations)
    sigma = validation.positive("sigma", sigma, "S/m")
    code = validation.model_code(model, MODELS)
    medium = sea_module.medium(sea, sigma)
    sea_module.check_column(sea, states, stations, model)
    validation.no_target_on_station(states, stations)
    n_s = stations.shape[0]
    e = np.empty((states.shape[0], n_s, 3))
    jac = np.empty((states.shape[0], n_s, 3, 7))
    kernels.field_and_jacobian(states, stations, 1.0 / (4.0 * np.pi * sigma), code, medium, e, jac)
    return e.reshape(lead + (n_s, 3)), jac.reshape(lead + (n_s, 3, 7))


def dipole_field(states, stations, *, sigma=4.0, model="exact", sea=None):
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
    sea : core.Sea or None
        ``None``: the homogeneous whole space. A :class:`core.Sea`: air / seawater / seabed
        (spec §7), z is depth (surface 0, seabed D) and targets and stations must lie in
        0 ≤ z ≤ D; the field is the image series of :mod:`core.sea`. Only ``model="exact"``.

    Returns
    -------
    E : ndarray, shape (..., S, 3)
        ``(Ex, Ey, Ez)`` in V/m at every station.

    Raises
    ------
    ValueError
        Wrong shapes, non-finite values, zero speed, σ ≤ 0, unknown model, or a target at a
        station (D = 0, where the field is singular); with a sea, a target or station outside
        the water column, or ``model="paper"``.

    Examples
    --------
    On the dipole axis the exact field is ``2 p / (4 π σ D³)``:

    >>> import numpy as np, core
    >>> E = core.dipole_field([0, 0, 0, 1, 0, 100, 0], [[10, 0, 0]], sigma=1.0)
    >>> bool(np.isclose(E[0, 0], 2 * 100 / (4 * np.pi * 1000)))
    True
    """
    return _field_and_jacobian(states, stations, sigma, model, sea)[0]


def field_jacobian(states, stations, *, sigma=4.0, model="exact", sea=None):
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
    return _field_and_jacobian(states, stations, sigma, model, sea)[1]
