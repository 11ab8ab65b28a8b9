"""Compiled kernels that build Γ point by point and reduce it to scalar measures.

Private: they assume validated float64 input (see :mod:`core.validation`) and never allocate
per point. Work is split into blocks of ``_BLOCK`` points run in parallel (``prange``); each
block owns its scratch buffers, so a 1000 × 1000 map needs no more memory than its outputs.

Column scaling is used throughout: with ``Γ_s = Γ / ‖Γ_j‖`` (unit columns),

    log10|det Γ| = log10|det Γ_s| + Σ_j log10 ‖Γ_j‖,

and ``η = sqrt(det Γ_sᵀ Γ_s) ∈ [0, 1]`` (for square Γ, ``|det Γ_s|``, the Hadamard ratio) is the
scale-free observability index: 1 for orthogonal columns, 0 for a rank-deficient Γ.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .fields import FASTMATH, _local_jacobian
from .validation import ON_STATION

_BLOCK = 256


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _gamma_point(x, stations, step, kappa, model, free, n_rows, nbuf, dndr, dndf, e, jac, g):
    """Fill ``g`` (n_rows, n_free) with the first ``n_rows`` rows of Γ at state ``x`` (7,).
    Returns False, with ``g`` incomplete, if the target comes within ON_STATION of a station.

    Rows are time-major, then station-major, then component (Ex, Ey, Ez): the paper's order.
    Row block of instant i is ``(∂h/∂X)(Φ^i x) · Φ^i``; Φ^i adds i·T·(∂/∂x, ∂/∂y) to the
    velocity columns (constant-velocity motion, no vertical speed).
    """
    n_s = stations.shape[0]
    row = 0
    i = 0
    while row < n_rows:
        dt = i * step
        px = x[0] + dt * x[3]
        py = x[1] + dt * x[4]
        for s in range(n_s):
            if row >= n_rows:
                break
            rx = px - stations[s, 0]
            ry = py - stations[s, 1]
            rz = x[2] - stations[s, 2]
            if rx * rx + ry * ry + rz * rz < ON_STATION * ON_STATION:
                return False
            _local_jacobian(
                rx, ry, rz,
                x[3], x[4], x[5], x[6], kappa, model, nbuf, dndr, dndf, e, jac,
            )
            for comp in range(3):
                if row >= n_rows:
                    break
                for q in range(free.shape[0]):
                    col = free[q]
                    v = jac[comp, col]
                    if col == 3:
                        v += dt * jac[comp, 0]  # Φ^i: ∂x_{k+i}/∂vx_k = i·T
                    elif col == 4:
                        v += dt * jac[comp, 1]  # Φ^i: ∂y_{k+i}/∂vy_k = i·T
                    g[row, q] = v
                row += 1
        i += 1
    return True


@nb.njit(cache=True, parallel=True, nogil=True, fastmath=FASTMATH)
def fill_gamma(states, stations, step, kappa, model, free, n_rows, out):
    """Γ for every state: states (P, 7) -> out (P, n_rows, n_free) (NaN on stations)."""
    npts = states.shape[0]
    for b in nb.prange((npts + _BLOCK - 1) // _BLOCK):
        nbuf = np.empty(3)
        dndr = np.empty((3, 3))
        dndf = np.empty((3, 4))
        e = np.empty(3)
        jac = np.empty((3, 7))
        for p in range(b * _BLOCK, min(npts, (b + 1) * _BLOCK)):
            if not _gamma_point(states[p], stations, step, kappa, model, free, n_rows,
                                nbuf, dndr, dndf, e, jac, out[p]):
                out[p] = np.nan


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _log10_column_norms(g, lognorm):
    """lognorm[j] = log10 ‖g_j‖ (-inf for a zero column); returns their sum."""
    total = 0.0
    for j in range(g.shape[1]):
        acc = 0.0
        for r in range(g.shape[0]):
            acc += g[r, j] * g[r, j]
        lognorm[j] = 0.5 * math.log10(acc) if acc > 0.0 else -np.inf
        total += lognorm[j]
    return total


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _log10_norm_product(g):
    """Σ_j log10 ‖g_j‖ with one logarithm (the hot path), per column only if the product of
    squared norms leaves float64's normal range."""
    prod = 1.0
    for j in range(g.shape[1]):
        acc = 0.0
        for r in range(g.shape[0]):
            acc += g[r, j] * g[r, j]
        prod *= acc
    if 1e-300 < prod < 1e300:
        return 0.5 * math.log10(prod)
    total = 0.0
    for j in range(g.shape[1]):
        acc = 0.0
        for r in range(g.shape[0]):
            acc += g[r, j] * g[r, j]
        total += 0.5 * math.log10(acc) if acc > 0.0 else -np.inf
    return total


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _lu_abs_det(a):
    """|det a| of a square matrix (n ≤ 63) by Gaussian elimination with partial pivoting;
    destroys ``a``.

    Rows are never swapped: a bitmask marks the rows already used as pivots. That keeps the
    inner loops free of data-dependent row indices, which measured 2–3× faster than swapping
    for 7 × 7 (bench/). Row pivoting picks the same pivots for ``a`` and for ``a`` with scaled
    columns, so no column scaling is needed: det Γ_s = det Γ / Π‖Γ_j‖ up to rounding.
    """
    n = a.shape[0]
    det = 1.0
    used = 0
    for k in range(n):
        piv = -1
        big = -1.0
        for r in range(n):
            if (used >> r) & 1 == 0:
                v = abs(a[r, k])
                if v > big:
                    big = v
                    piv = r
        if big == 0.0:
            return 0.0
        used |= 1 << piv
        det *= big
        inv = 1.0 / a[piv, k]
        for r in range(n):
            if (used >> r) & 1 == 0:
                f = a[r, k] * inv
                for c in range(k + 1, n):
                    a[r, c] -= f * a[piv, c]
    return det


@nb.njit(cache=True, parallel=True, nogil=True, fastmath=FASTMATH)
def square_measures(states, stations, step, kappa, model, free, log_det, log_eta):
    """Paper rule: square Γ (n_free rows). Writes log10|det Γ| and log10 η per point (NaN on
    stations)."""
    npts = states.shape[0]
    n = free.shape[0]
    for b in nb.prange((npts + _BLOCK - 1) // _BLOCK):
        nbuf = np.empty(3)
        dndr = np.empty((3, 3))
        dndf = np.empty((3, 4))
        e = np.empty(3)
        jac = np.empty((3, 7))
        g = np.empty((n, n))
        for p in range(b * _BLOCK, min(npts, (b + 1) * _BLOCK)):
            if not _gamma_point(states[p], stations, step, kappa, model, free, n,
                                nbuf, dndr, dndf, e, jac, g):
                log_det[p] = np.nan
                log_eta[p] = np.nan
                continue
            norms = _log10_norm_product(g)
            det = _lu_abs_det(g)
            ld = math.log10(det) if det > 0.0 else -np.inf
            log_det[p] = ld
            log_eta[p] = ld - norms


@nb.njit(cache=True, inline="always", fastmath=FASTMATH)
def _householder_r(g, rdiag):
    """Householder QR of g (m × n, m ≥ n) in place: R's strict upper part stays in g, its
    diagonal goes to ``rdiag``. Q is not kept. Backward stable, unlike forming ΓᵀΓ, so an
    exactly singular Γ gives |R_nn| at round-off level (~1e-16), not its square root."""
    m, n = g.shape
    for k in range(n):
        norm2 = 0.0
        for r in range(k, m):
            norm2 += g[r, k] * g[r, k]
        if norm2 == 0.0:
            rdiag[k] = 0.0
            continue
        alpha = -math.sqrt(norm2) if g[k, k] >= 0.0 else math.sqrt(norm2)
        g[k, k] -= alpha  # v = x − α e₁ stored in column k
        vnorm2 = norm2 - 2.0 * alpha * (g[k, k] + alpha) + alpha * alpha
        rdiag[k] = alpha
        if vnorm2 == 0.0:
            continue
        for j in range(k + 1, n):
            dot = 0.0
            for r in range(k, m):
                dot += g[r, k] * g[r, j]
            t = 2.0 * dot / vnorm2
            for r in range(k, m):
                g[r, j] -= t * g[r, k]


@nb.njit(cache=True, parallel=True, nogil=True, fastmath=FASTMATH)
def fisher_measures(states, stations, step, kappa, model, free, n_rows,
                    log_eta, log_norm_sum, inv_diag):
    """All-rows Γ (n_rows × n_free) reduced through its QR factorisation.

    Per point: ``log_eta`` = log10 η, η = sqrt(det Γ_sᵀΓ_s) = Π|R_jj| of the unit-column Γ_s;
    ``log_norm_sum`` = Σ log10 ‖Γ_j‖; ``inv_diag`` (P, n_free) = diag((ΓᵀΓ)⁻¹) (times the
    noise variance, the CRLB variances). The caller decides observability from η. NaN on
    stations.
    """
    npts = states.shape[0]
    n = free.shape[0]
    for b in nb.prange((npts + _BLOCK - 1) // _BLOCK):
        nbuf = np.empty(3)
        dndr = np.empty((3, 3))
        dndf = np.empty((3, 4))
        e = np.empty(3)
        jac = np.empty((3, 7))
        g = np.empty((n_rows, n))
        lognorm = np.empty(n)
        rdiag = np.empty(n)
        rinv = np.empty((n, n))
        for p in range(b * _BLOCK, min(npts, (b + 1) * _BLOCK)):
            if not _gamma_point(states[p], stations, step, kappa, model, free, n_rows,
                                nbuf, dndr, dndf, e, jac, g):
                log_eta[p] = np.nan
                log_norm_sum[p] = np.nan
                inv_diag[p] = np.nan
                continue
            log_norm_sum[p] = _log10_column_norms(g, lognorm)
            for j in range(n):  # unit columns: Γ_s = Γ / ‖Γ_j‖
                scale = 10.0 ** -lognorm[j] if lognorm[j] > -np.inf else 0.0
                for r in range(n_rows):
                    g[r, j] *= scale
            # 1. η = Π |R_jj| of Γ_s = QR.
            _householder_r(g, rdiag)
            le = 0.0
            singular = False
            for j in range(n):
                if rdiag[j] == 0.0:
                    singular = True
                else:
                    le += math.log10(abs(rdiag[j]))
            log_eta[p] = -np.inf if singular else le
            if singular:
                for j in range(n):
                    inv_diag[p, j] = np.inf
                continue
            # 2. (Γ_sᵀΓ_s)⁻¹ = R⁻¹ R⁻ᵀ: its diagonal is the row sums of (R⁻¹)². Back substitution.
            for k in range(n):
                for i in range(n - 1, -1, -1):
                    if i > k:
                        rinv[i, k] = 0.0
                        continue
                    acc = 1.0 if i == k else 0.0
                    for j in range(i + 1, k + 1):
                        acc -= g[i, j] * rinv[j, k]
                    rinv[i, k] = acc / rdiag[i]
            for i in range(n):
                acc = 0.0
                for k in range(i, n):
                    acc += rinv[i, k] * rinv[i, k]
                # undo the column scaling: (ΓᵀΓ)⁻¹_ii = (Γ_sᵀΓ_s)⁻¹_ii / ‖Γ_i‖²
                inv_diag[p, i] = acc / 10.0 ** (2.0 * lognorm[i])


@nb.njit(cache=True, nogil=True)
def grid_states(template, u, v, v_index, out):
    """States on a plane: out[i, j] = template with x = u[j] and state[v_index] = v[i].
    Serial: it is memory-bound, and a thread team costs more than it saves."""
    for i in range(v.shape[0]):
        for j in range(u.shape[0]):
            for k in range(7):
                out[i, j, k] = template[k]
            out[i, j, 0] = u[j]
            out[i, j, v_index] = v[i]
