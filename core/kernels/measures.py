"""Compiled measures of Γ, LANES points side by side, for every sensor kind: log10|det Γ|, the
observability index η, the rank test's rcond and the Fisher information's CRLB variances.

Private: they assume validated float64 input and never allocate per point. Γ's rows come from
:mod:`.gamma` (the one place where a kind picks its rows); everything here is shared. Work is
split into ``CHUNKS`` runs of groups of LANES points, run in parallel (``prange``); each run owns
its workspace, so a 1000 × 1000 map needs no more memory than its outputs.

Column scaling is used throughout: with ``Γ_s = Γ / ‖Γ_j‖`` (unit columns),

    log10|det Γ| = log10|det Γ_s| + Σ_j log10 ‖Γ_j‖,

and ``η = sqrt(det Γ_sᵀ Γ_s) ∈ [0, 1]`` (for square Γ, ``|det Γ_s|``, the Hadamard ratio) is the
scale-free observability index: 1 for orthogonal columns, 0 for a rank-deficient Γ.

The rank test (:data:`core.observability.gamma.RANK_RTOL`) reads ``rcond = 1 / (‖Γ_s‖_F ‖R_s⁻¹‖_F)``,
the reciprocal Frobenius condition number of Γ_s (R_s its R factor), which brackets the ratio of
extreme singular values: ``rcond ≤ σ_min/σ_max ≤ n · rcond``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .electric import JIT
from .gamma import (
    BAD,
    BETA,
    CHUNKS,
    DET,
    DIAG,
    DOT,
    G,
    J,
    LANES,
    NORM2,
    NX,
    ROWS,
    SQ,
    T,
    N,
    assemble_lanes,
    components,
    gamma_row_lanes,
    load_lanes,
    row_stride,
    rows_lanes,
)


@nb.njit(inline="always", **JIT)
def _qr_abs_det_lanes(w, n):
    """w[DET] = |det| of the n × n matrices in w[G…] (destroyed), one per lane: the product
    of |R_kk| of a Householder QR. Branch-free across lanes (unlike pivoting), and backward
    stable; column scaling commutes with it, so none is needed."""
    for lane in range(LANES):
        w[DET, lane] = 1.0
    for k in range(n):
        kk = G + DIAG * k
        for lane in range(LANES):
            w[NORM2, lane] = 0.0  # ‖column k below the diagonal‖²
        for r in range(k, n):
            rk = G + N * r + k
            for lane in range(LANES):
                w[NORM2, lane] += w[rk, lane] * w[rk, lane]
        for lane in range(LANES):
            norm2, top = w[NORM2, lane], w[kk, lane]
            alpha = -math.sqrt(norm2) if top >= 0.0 else math.sqrt(norm2)
            v0 = top - alpha  # Householder vector v = x − α e₁, stored over column k
            vnorm2 = norm2 - top * top + v0 * v0
            w[kk, lane] = v0
            w[BETA, lane] = 2.0 / vnorm2 if vnorm2 > 0.0 else 0.0
            w[DET, lane] *= abs(alpha)
            w[T, lane] = alpha  # R_kk, stored over v0 once the columns right of k are done
        for c in range(k + 1, n):
            for lane in range(LANES):
                w[DOT, lane] = 0.0
            for r in range(k, n):
                rk, rc = G + N * r + k, G + N * r + c
                for lane in range(LANES):
                    w[DOT, lane] += w[rk, lane] * w[rc, lane]
            for lane in range(LANES):
                w[DOT, lane] *= w[BETA, lane]
            for r in range(k, n):
                rk, rc = G + N * r + k, G + N * r + c
                for lane in range(LANES):
                    w[rc, lane] -= w[DOT, lane] * w[rk, lane]
        for lane in range(LANES):
            w[kk, lane] = w[T, lane]  # R (upper triangle, signed diagonal) is now in w[G…]


@nb.njit(inline="always", **JIT)
def _rinv_scaled_frobenius2_lanes(w, n):
    """w[NORM2] = ‖R_s⁻¹‖_F² = Σ_i ‖Γ_i‖² Σ_k (R⁻¹)_ik² for the R in w[G…] (upper triangle)
    and the squared column norms in w[SQ…], one column of R⁻¹ at a time (back substitution
    into the free rows w[J:J+NX]). inf or NaN where an R_jj is 0."""
    for lane in range(LANES):
        w[NORM2, lane] = 0.0
    for k in range(n):
        for i in range(k, -1, -1):
            xi = J + i
            for lane in range(LANES):
                w[xi, lane] = 1.0 if i == k else 0.0
            for j in range(i + 1, k + 1):
                ij, xj = G + N * i + j, J + j
                for lane in range(LANES):
                    w[xi, lane] -= w[ij, lane] * w[xj, lane]
            ii, si = G + DIAG * i, SQ + i
            for lane in range(LANES):
                w[xi, lane] /= w[ii, lane]
                w[NORM2, lane] += w[si, lane] * w[xi, lane] * w[xi, lane]


@nb.njit(inline="always", **JIT)
def _log10_rcond(frob2, n):
    """log10(1 / (√n ‖R_s⁻¹‖_F)) from ‖R_s⁻¹‖_F²; -inf where that is not finite (singular R)."""
    if frob2 > 0.0 and frob2 < np.inf:
        return -0.5 * math.log10(n * frob2)
    return -np.inf


@nb.njit(**JIT)
def _square_groups(states, first, last, stations, step, kappa, model, medium, free, log_det,
                   log_eta, log_rcond):
    """:func:`square_measures` for the groups of LANES points ``first`` … ``last − 1``. The
    workspace is allocated here once (not per group, whose pages malloc would hand back to the
    OS and fault in again), with a shape known at compile time so that LLVM sees its stride."""
    n = free.shape[0]
    w = np.empty((ROWS, LANES))
    for group in range(first, last):
        p0 = group * LANES
        count = load_lanes(w, states, p0)
        assemble_lanes(w, stations, step, kappa, model, medium, free)
        for j in range(n):
            for lane in range(LANES):
                w[SQ + j, lane] = 0.0
            for r in range(n):
                rj = G + N * r + j
                for lane in range(LANES):
                    w[SQ + j, lane] += w[rj, lane] * w[rj, lane]
        _qr_abs_det_lanes(w, n)
        _rinv_scaled_frobenius2_lanes(w, n)
        for lane in range(count):
            p = p0 + lane
            if w[BAD, lane] != 0.0:
                log_det[p] = np.nan
                log_eta[p] = np.nan
                log_rcond[p] = np.nan
                continue
            log_rcond[p] = _log10_rcond(w[NORM2, lane], n)
            prod = 1.0
            for j in range(n):
                prod *= w[SQ + j, lane]
            if 1e-300 < prod < 1e300:  # one logarithm on the hot path
                norms = 0.5 * math.log10(prod)
            else:
                norms = 0.0
                for j in range(n):
                    sq = w[SQ + j, lane]
                    norms += 0.5 * math.log10(sq) if sq > 0.0 else -np.inf
            det = w[DET, lane]
            ld = math.log10(det) if det > 0.0 else -np.inf
            log_det[p] = ld
            log_eta[p] = ld - norms


@nb.njit(parallel=True, nogil=True, **JIT)
def square_measures(states, stations, step, kappa, model, medium, free, log_det, log_eta,
                    log_rcond):
    """Paper rule: square Γ (n_free rows). Writes log10|det Γ|, log10 η and log10 rcond per
    point (NaN on stations), LANES points at a time."""
    groups = (states.shape[0] + LANES - 1) // LANES
    chunks = min(groups, CHUNKS)
    for c in nb.prange(chunks):
        _square_groups(states, c * groups // chunks, (c + 1) * groups // chunks, stations, step, kappa,
                       model, medium, free, log_det, log_eta, log_rcond)


# Workspace rows of fisher_measures beyond the shared ones: R (NX × NX at G), the
# incoming row of Γ (at T), Givens cosines/sines, R⁻¹ (NX × NX).
_COS, _SIN, _RINV = BAD + 1, BAD + 2, BAD + 3
_FISHER_ROWS = _RINV + NX * NX


@nb.njit(inline="always", **JIT)
def _givens_update(w, n):
    """Fold the row w[T:T+n] into the upper-triangular R (w[G + N j + k]) by Givens
    rotations: R ← the R of QR([R; row]), R_jj ≥ 0. Backward stable (forming ΓᵀΓ is not: it
    would square the round-off of an exactly singular Γ)."""
    for j in range(n):
        jj, tj = G + DIAG * j, T + j
        for lane in range(LANES):
            a, b = w[jj, lane], w[tj, lane]
            r = math.sqrt(a * a + b * b)
            nonzero = r > 0.0
            w[_COS, lane] = a / r if nonzero else 1.0
            w[_SIN, lane] = b / r if nonzero else 0.0
            w[jj, lane] = r
        for k in range(j + 1, n):
            jk, tk = G + N * j + k, T + k
            for lane in range(LANES):
                rk, xk, c, s = w[jk, lane], w[tk, lane], w[_COS, lane], w[_SIN, lane]
                w[jk, lane] = c * rk + s * xk
                w[tk, lane] = c * xk - s * rk


@nb.njit(inline="always", **JIT)
def _inverse_lanes(w, n):
    """R⁻¹ (upper triangular) into w[_RINV + N i + k] by back substitution; inf/NaN where an
    R_jj is 0 (the caller masks those lanes)."""
    for k in range(n):
        for i in range(k, -1, -1):
            ik = _RINV + N * i + k
            for lane in range(LANES):
                w[ik, lane] = 1.0 if i == k else 0.0
            for j in range(i + 1, k + 1):
                ij, jk = G + N * i + j, _RINV + N * j + k
                for lane in range(LANES):
                    w[ik, lane] -= w[ij, lane] * w[jk, lane]
            ii = G + DIAG * i
            for lane in range(LANES):
                w[ik, lane] /= w[ii, lane]


@nb.njit(**JIT)
def _fisher_groups(states, first, last, stations, step, kappa, model, medium, free, n_rows,
                   log_eta, log_norm_sum, inv_diag, log_rcond):
    """:func:`fisher_measures` for the groups ``first`` … ``last − 1`` (see :func:`_square_groups`)."""
    n = free.shape[0]
    n_c, stride = components(model), row_stride(model)
    w = np.empty((_FISHER_ROWS, LANES))
    for group in range(first, last):
        p0 = group * LANES
        count = load_lanes(w, states, p0)
        for r in range(G, G + NX * NX):
            w[r] = 0.0
        for j in range(n):
            w[SQ + j] = 0.0
        for i in range(n_rows // (n_c * stations.shape[0])):
            for s in range(stations.shape[0]):
                rows_lanes(w, i * step, stations, s, kappa, model, medium)
                for comp in range(n_c):
                    gamma_row_lanes(w, T, comp, stride, i * step, free)
                    for j in range(n):
                        for lane in range(LANES):
                            w[SQ + j, lane] += w[T + j, lane] * w[T + j, lane]
                    _givens_update(w, n)
        _inverse_lanes(w, n)
        for lane in range(count):
            p = p0 + lane
            if w[BAD, lane] != 0.0:
                log_eta[p] = np.nan
                log_norm_sum[p] = np.nan
                inv_diag[p] = np.nan
                log_rcond[p] = np.nan
                continue
            norms = 0.0
            log_r = 0.0
            singular = False
            for j in range(n):
                sq, rjj = w[SQ + j, lane], w[G + DIAG * j, lane]
                norms += 0.5 * math.log10(sq) if sq > 0.0 else -np.inf
                if rjj > 0.0:
                    log_r += math.log10(rjj)
                else:
                    singular = True
            log_norm_sum[p] = norms
            # η = Π R_jj / Π ‖Γ_j‖ (the R of the unit-column Γ_s is R with unit-scaled columns)
            log_eta[p] = -np.inf if singular else log_r - norms
            frob2 = 0.0  # ‖R_s⁻¹‖_F² = Σ_i ‖Γ_i‖² (R⁻¹R⁻ᵀ)_ii
            for i in range(n):
                acc = 0.0
                for k in range(i, n):
                    v = w[_RINV + N * i + k, lane]
                    acc += v * v
                # (ΓᵀΓ)⁻¹ = R⁻¹ R⁻ᵀ: its diagonal is the row sums of (R⁻¹)²
                inv_diag[p, i] = np.inf if singular else acc
                frob2 += w[SQ + i, lane] * acc
            log_rcond[p] = -np.inf if singular else _log10_rcond(frob2, n)


@nb.njit(parallel=True, nogil=True, **JIT)
def fisher_measures(states, stations, step, kappa, model, medium, free, n_rows,
                    log_eta, log_norm_sum, inv_diag, log_rcond):
    """All-rows Γ (n_rows × n_free, N = n_rows / (N_COMPONENTS · S) instants) reduced through its QR
    factorisation, LANES points at a time, without storing Γ.

    Per point: ``log_eta`` = log10 η, η = sqrt(det Γ_sᵀΓ_s) = Π|R_jj| of the unit-column Γ_s;
    ``log_norm_sum`` = Σ log10 ‖Γ_j‖; ``inv_diag`` (P, n_free) = diag((ΓᵀΓ)⁻¹) (times the
    noise variance, the CRLB variances); ``log_rcond`` = log10 rcond (module docstring), from
    which the caller decides the rank. NaN on stations.
    """
    groups = (states.shape[0] + LANES - 1) // LANES
    chunks = min(groups, CHUNKS)
    for c in nb.prange(chunks):
        _fisher_groups(states, c * groups // chunks, (c + 1) * groups // chunks, stations, step, kappa,
                       model, medium, free, n_rows, log_eta, log_norm_sum, inv_diag, log_rcond)


