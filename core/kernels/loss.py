"""Compiled loss of a station (:mod:`core.observability.loss`): per point, the information of each
station from Γ's rows, computed once, then for each lost station k the diagonal of the inverse
of the others' sum.

Private: assumes validated float64 input. :func:`loss_measures` builds Γ's rows LANES points at
a time through :mod:`.gamma` (the one place where a kind picks its rows), as
:func:`core.kernels.measures.fisher_measures` does, without storing Γ. Work is split into
``CHUNKS`` runs, run in parallel (``prange``); each run owns its workspace.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .electric import JIT
from .gamma import (BAD, CHUNKS, LANES, NX, ROWS, T, components, gamma_row_lanes, load_lanes,
                    row_stride, rows_lanes)


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
def _loss_groups(states, first, last, stations, step, kappa, model, medium, free, n_rows,
                 inv_diag, cond):
    """:func:`loss_measures` for the groups of LANES points ``first`` … ``last − 1``."""
    n, n_st = free.shape[0], stations.shape[0]
    n_c, stride = components(model), row_stride(model)
    w = np.empty((max(ROWS, T + NX), LANES))
    info = np.empty((n_st, n, n, LANES))  # per-station Γ_sᵀΓ_s, upper triangle, per lane
    a = np.empty((n, n))
    low = np.zeros((n, n))
    linv = np.zeros((n, n))
    d = np.empty(n)
    for group in range(first, last):
        p0 = group * LANES
        count = load_lanes(w, states, p0)
        info[:] = 0.0
        for i in range(n_rows // (n_c * n_st)):
            for s in range(n_st):
                rows_lanes(w, i * step, stations, s, kappa, model, medium)
                for comp in range(n_c):
                    gamma_row_lanes(w, T, comp, stride, i * step, free)
                    for j in range(n):
                        for k in range(j, n):
                            for lane in range(LANES):
                                info[s, j, k, lane] += w[T + j, lane] * w[T + k, lane]
        for lane in range(count):
            p = p0 + lane
            if w[BAD, lane] != 0.0:  # on a station
                inv_diag[p] = np.nan
                cond[p] = np.nan
                continue
            for k in range(n_st):
                for i in range(n):  # Σ_{s≠k} F_s
                    for j in range(i, n):
                        acc = 0.0
                        for s in range(n_st):
                            if s != k:
                                acc += info[s, i, j, lane]
                        a[i, j] = acc
                cond[p, k] = _scaled_inverse_diag(a, d, low, linv, inv_diag[p, k])


@nb.njit(parallel=True, nogil=True, **JIT)
def loss_measures(states, stations, step, kappa, model, medium, free, n_rows, inv_diag, cond):
    """All-rows Γ of every station (n_rows = N · components · S rows), per point: ``inv_diag``
    (P, S, n_free) = diag((Σ_{s≠k} Γ_sᵀΓ_s)⁻¹) with station k lost, and ``cond`` (P, S) the
    bound on the condition number of its unit-diagonal scaling (+inf, ``inv_diag`` NaN, where
    Cholesky breaks down; NaN on a station). Arguments as
    :func:`core.kernels.measures.fisher_measures`."""
    groups = (states.shape[0] + LANES - 1) // LANES
    chunks = min(groups, CHUNKS)
    for c in nb.prange(chunks):
        _loss_groups(states, c * groups // chunks, (c + 1) * groups // chunks, stations, step,
                     kappa, model, medium, free, n_rows, inv_diag, cond)
