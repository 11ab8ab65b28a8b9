"""Compiled steps of the extended Kalman filters of :mod:`core.tracking.filters` (the prediction,
the guarded, progressive update and the NEES), on stacks of independent filters. A leaf, as
every module of :mod:`core.kernels`: numpy and numba only.

Generic over the measurement model: the state size n and the measurement size m are read from
the arrays (n = 7 electric, 8 magnetic; m = the stacked components of the stations), and the
noise of each component is its own (``r_weight``: a B + G sensor mixes nT and nT/m).
"""

from __future__ import annotations

import numba as nb
import numpy as np

#: Smallest speed (m/s) at which a filter linearises the measurement (the heading needs one).
MIN_SPEED = 1e-3
#: Smallest distance (m) from a station at which a filter linearises the measurement.
MIN_STATION_DISTANCE = 1e-3
_LOG_2PI = np.log(2.0 * np.pi)


@nb.njit(cache=True, nogil=True)
def _predict_kernel(P, F, Q, out):
    """out[f] = F P[f] Fᵀ + Q for (N, n, n) P."""
    n = P.shape[1]
    FP = np.empty((n, n))
    for f in range(P.shape[0]):
        for i in range(n):
            for j in range(n):
                acc = 0.0
                for q in range(n):
                    acc += F[i, q] * P[f, q, j]
                FP[i, j] = acc
        for i in range(n):
            for j in range(i + 1):
                acc = Q[i, j]
                for q in range(n):
                    acc += FP[i, q] * F[j, q]
                out[f, i, j] = acc
                out[f, j, i] = acc


@nb.njit(cache=True, nogil=True)
def _nees_kernel(P, err, out):
    """out[f] = err[f]ᵀ P[f]⁻¹ err[f] by Cholesky; NaN where P[f] is not positive definite."""
    n = P.shape[1]
    L = np.empty((n, n))
    z = np.empty(n)
    for f in range(P.shape[0]):
        if _cholesky(P[f], L):
            _cholesky_solve(L, err[f], z)
            acc = 0.0
            for i in range(n):
                acc += err[f, i] * z[i]
            out[f] = acc
        else:
            out[f] = np.nan


@nb.njit(cache=True, nogil=True)
def _cholesky_solve(L, b, z):
    """Solve (L Lᵀ) z = b into z (m,), L lower triangular (m, m); b is not changed."""
    m = b.shape[0]
    for i in range(m):
        z[i] = b[i]
    for i in range(m):  # L w = b
        acc = z[i]
        for j in range(i):
            acc -= L[i, j] * z[j]
        z[i] = acc / L[i, i]
    for i in range(m - 1, -1, -1):  # Lᵀ z = w
        acc = z[i]
        for j in range(i + 1, m):
            acc -= L[j, i] * z[j]
        z[i] = acc / L[i, i]


@nb.njit(cache=True, nogil=True)
def _cholesky(S, L):
    """Lower Cholesky factor of S (m, m) into L; False if S is not positive definite."""
    m = S.shape[0]
    for i in range(m):
        for j in range(i + 1):
            acc = S[i, j]
            for q in range(j):
                acc -= L[i, q] * L[j, q]
            if i == j:
                if not acc > 0.0:  # also catches NaN
                    return False
                L[i, i] = np.sqrt(acc)
            else:
                L[i, j] = acc / L[j, j]
        for j in range(i + 1, m):
            L[i, j] = 0.0
    return True


@nb.njit(cache=True, nogil=True)
def _update_kernel(x, P, nu, H, r_update, r_like, r_weight, want_like, like):
    """One (sub-)update of N filters in place: x (N, n), P (N, n, n), innovation nu (N, m),
    H (N, m, n), noise variance r_update · r_weight[r] of component r (r_weight (m,), 1.0 for
    equal noise: then the arithmetic is that of a scalar r_update); with want_like, also the
    Gaussian log-likelihood of nu under H P Hᵀ + r_like · diag(r_weight) into like (N,). A filter
    whose S is not positive definite gets NaN (it is then dead)."""
    n_f, m = nu.shape
    n = x.shape[1]
    PHt = np.empty((n, m))
    S = np.empty((m, m))
    L = np.empty((m, m))
    K = np.empty((n, m))
    A = np.empty((n, n))
    AP = np.empty((n, n))
    z = np.empty(m)
    for f in range(n_f):
        for i in range(n):  # P Hᵀ (n, m)
            for r in range(m):
                acc = 0.0
                for j in range(n):
                    acc += P[f, i, j] * H[f, r, j]
                PHt[i, r] = acc
        for r in range(m):  # H P Hᵀ (m, m), symmetric
            for c in range(r + 1):
                acc = 0.0
                for j in range(n):
                    acc += H[f, r, j] * PHt[j, c]
                S[r, c] = acc
                S[c, r] = acc
        if want_like:
            for r in range(m):
                S[r, r] += r_like * r_weight[r]
            if _cholesky(S, L):
                _cholesky_solve(L, nu[f], z)
                quad = 0.0
                logdet = 0.0
                for r in range(m):
                    quad += nu[f, r] * z[r]
                    logdet += 2.0 * np.log(L[r, r])
                like[f] = -0.5 * (quad + logdet + m * _LOG_2PI)
            else:
                like[f] = np.nan
            for r in range(m):
                S[r, r] += (r_update - r_like) * r_weight[r]
        else:
            for r in range(m):
                S[r, r] += r_update * r_weight[r]
        if not _cholesky(S, L):
            x[f, :] = np.nan
            continue
        for i in range(n):  # K = P Hᵀ S⁻¹, row by row: S K[i]ᵀ = (P Hᵀ)[i]ᵀ
            _cholesky_solve(L, PHt[i], K[i])
        for i in range(n):
            acc = 0.0
            for r in range(m):
                acc += K[i, r] * nu[f, r]
            x[f, i] += acc
        for i in range(n):  # A = I − K H
            for j in range(n):
                acc = 1.0 if i == j else 0.0
                for r in range(m):
                    acc -= K[i, r] * H[f, r, j]
                A[i, j] = acc
        for i in range(n):  # A P
            for j in range(n):
                acc = 0.0
                for q in range(n):
                    acc += A[i, q] * P[f, q, j]
                AP[i, j] = acc
        for i in range(n):  # Joseph form: A P Aᵀ + K R Kᵀ, symmetric
            for j in range(i + 1):
                acc = 0.0
                for q in range(n):
                    acc += AP[i, q] * A[j, q]
                kk = 0.0
                for r in range(m):
                    kk += K[i, r] * K[j, r] * r_weight[r]
                acc += r_update * kk
                P[f, i, j] = acc
                P[f, j, i] = acc
