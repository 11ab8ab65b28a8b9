"""Compiled loss of a station (:mod:`core.observability.loss`): per point, the information of each
station from Γ's rows, computed once, then for each lost station k the diagonal of the inverse
of the others' sum.

Private: assumes a validated float64 Γ stack whose rows are time-major, then station-major,
then component (:mod:`.gamma`'s order). Work is split into ``CHUNKS`` runs of points, run in
parallel (``prange``); each run owns its workspace.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .electric import JIT
from .gamma import CHUNKS


@nb.njit(inline="always", **JIT)
def _station_information(g, p, n_st, n_comp, info):
    """info[s] (upper triangle) = Γ_sᵀΓ_s of point p: the rows of station s over every instant."""
    n = g.shape[2]
    info[:] = 0.0
    for t in range(g.shape[1] // (n_st * n_comp)):
        for s in range(n_st):
            for c in range(n_comp):
                r = (t * n_st + s) * n_comp + c
                for j in range(n):
                    gj = g[p, r, j]
                    for k in range(j, n):
                        info[s, j, k] += gj * g[p, r, k]


@nb.njit(inline="always", **JIT)
def _scaled_inverse_diag(a, d, low, linv, out):
    """out = diag(A⁻¹) of the symmetric A (upper triangle in ``a``) through the Cholesky factor
    of the unit-diagonal D⁻¹AD⁻¹ (d = sqrt(diag A)); returns n · trace((D⁻¹AD⁻¹)⁻¹), a bound on
    its condition number, or +inf (out NaN) where a pivot is not positive."""
    n = a.shape[0]
    for i in range(n):
        d[i] = math.sqrt(a[i, i])
    ok = True
    for j in range(n):  # L_ij = (A_ij − Σ_m L_im L_jm) / L_jj, column by column
        for i in range(j, n):
            acc = a[j, i] / (d[i] * d[j])
            for m in range(j):
                acc -= low[i, m] * low[j, m]
            if i == j:
                if not acc > 0.0:
                    ok = False
                    acc = 1.0
                low[j, j] = math.sqrt(acc)
            else:
                low[i, j] = acc / low[j, j]
    for j in range(n):  # L⁻¹ by forward substitution
        linv[j, j] = 1.0 / low[j, j]
        for i in range(j + 1, n):
            acc = 0.0
            for m in range(j, i):
                acc -= low[i, m] * linv[m, j]
            linv[i, j] = acc / low[i, i]
    trace = 0.0
    for j in range(n):  # (A_s⁻¹)_jj = Σ_i (L⁻¹)_ij², undo the scaling
        acc = 0.0
        for i in range(j, n):
            acc += linv[i, j] * linv[i, j]
        trace += acc
        out[j] = acc / (d[j] * d[j]) if ok else np.nan
    return n * trace if ok and trace < np.inf else np.inf


@nb.njit(**JIT)
def _loss_points(g, first, last, n_st, n_comp, inv_diag, kappa):
    n = g.shape[2]
    info = np.empty((n_st, n, n))
    a = np.empty((n, n))
    low = np.zeros((n, n))
    linv = np.zeros((n, n))
    d = np.empty(n)
    for p in range(first, last):
        _station_information(g, p, n_st, n_comp, info)
        for k in range(n_st):
            for i in range(n):  # Σ_{s≠k} F_s (no subtraction: no cancellation)
                for j in range(i, n):
                    acc = 0.0
                    for s in range(n_st):
                        if s != k:
                            acc += info[s, i, j]
                    a[i, j] = acc
            kappa[p, k] = _scaled_inverse_diag(a, d, low, linv, inv_diag[p, k])


@nb.njit(parallel=True, nogil=True, **JIT)
def loss_inverse_diag(g, n_st, n_comp, inv_diag, kappa):
    """For Γ (P, R, n) of ``n_st`` stations of ``n_comp`` components: ``inv_diag`` (P, S, n) =
    diag((Σ_{s≠k} Γ_sᵀΓ_s)⁻¹) and ``kappa`` (P, S) the bound n · trace(A_s⁻¹) on the condition
    number of its unit-diagonal scaling A_s (+inf, ``inv_diag`` NaN, where Cholesky breaks)."""
    npts = g.shape[0]
    chunks = min(npts, CHUNKS)
    for c in nb.prange(chunks):
        _loss_points(g, c * npts // chunks, (c + 1) * npts // chunks, n_st, n_comp, inv_diag,
                     kappa)
