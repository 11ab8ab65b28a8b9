"""Compiled kernels that build Γ point by point and reduce it to scalar measures.

Private: they assume validated float64 input (see :mod:`core.model.validation`) and never allocate
per point. Work is split into blocks of ``_BLOCK`` points (``LANES`` for the map kernels,
the hot paths, which compute their points side by side in vector registers) run in parallel
(``prange``); each block owns its scratch buffers, so a 1000 × 1000 map needs no more memory
than its outputs.

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

from .electric import (
    JIT,
    N_COMPONENTS,
    N_STATES,
    ON_STATION,
    ROW,
    STATION_ROWS,
    _local_jacobian,
    _store_rows,
)
from .sea import PAIR_ROWS, SEA_ROWS, _load, layered_lanes, station_rows

_BLOCK = 256
#: State columns of the horizontal velocity (vx, vy): Φ^i adds i·T·∂/∂(x, y) to them.
_VX, _VY = 3, 4


@nb.njit(parallel=True, nogil=True, **JIT)
def field_and_jacobian(states, stations, kappa, model, medium, e_out, j_out):
    """E and ∂E/∂X: states (P, N_STATES), stations (S, 3) -> e_out (P, S, N_COMPONENTS),
    j_out (P, S, N_COMPONENTS, N_STATES).
    ``medium`` = [D, η, tol] of :func:`core.model.sea.medium` (D = 0: whole space)."""
    npts = states.shape[0]
    for b in nb.prange((npts + _BLOCK - 1) // _BLOCK):
        w = np.empty((PAIR_ROWS, 1))  # the layered series' one-pair workspace
        for p in range(b * _BLOCK, min(npts, (b + 1) * _BLOCK)):
            x = states[p]
            for s in range(stations.shape[0]):
                rows = station_rows(w, x[0] - stations[s, 0], x[1] - stations[s, 1], x[2],
                                    stations[s, 2], x[3], x[4], x[5], x[6], kappa, model, medium)
                _store_rows(rows, e_out[p, s], j_out[p, s])


@nb.njit(**JIT)
def _pairs_run(states, p0, lanes, stations, kappa, medium, e_out, j_out, counts):
    """:func:`layered_pairs` for the run of ``lanes`` targets from ``p0``. (A function of its
    own, not inlined there: numba's parallel array analysis fails on the series' nested tuples.)"""
    npts = states.shape[0]
    w = np.empty((PAIR_ROWS, LANES))
    count = min(lanes, npts - p0)
    for s in range(stations.shape[0]):
        for lane in range(lanes):
            x = states[p0 + lane if lane < count else p0]
            w[0, lane], w[1, lane] = x[0] - stations[s, 0], x[1] - stations[s, 1]
            w[2, lane], w[3, lane] = x[2], stations[s, 2]
            w[4, lane], w[5, lane], w[6, lane], w[7, lane] = x[3], x[4], x[5], x[6]
        n_img = layered_lanes(w, 0, SEA_ROWS, lanes, kappa, medium[0], medium[1], medium[2])
        for lane in range(count):
            _store_rows(_load(w, SEA_ROWS, lane), e_out[p0 + lane, s], j_out[p0 + lane, s])
            counts[p0 + lane, s] = n_img


@nb.njit(parallel=True, nogil=True, **JIT)
def layered_pairs(states, stations, kappa, medium, lanes, e_out, j_out, counts):
    """The layered series (medium[0] = D > 0) of every target–station pair, ``lanes`` (≤ LANES)
    consecutive targets side by side per station, as the map kernels run it (a short last run
    repeats its first target): e_out (P, S, N_COMPONENTS), j_out (P, S, N_COMPONENTS, N_STATES),
    images per pair counts (P, S)."""
    npts = states.shape[0]
    for b in nb.prange((npts + lanes - 1) // lanes):
        _pairs_run(states, b * lanes, lanes, stations, kappa, medium, e_out, j_out, counts)


@nb.njit(**JIT)
def _gamma_point(x, stations, step, kappa, model, medium, free, n_rows, e, jac, w, g):
    """Fill ``g`` (n_rows, n_free) with the first ``n_rows`` rows of Γ at state ``x`` (N_STATES,).
    Returns False, with ``g`` incomplete, if the target comes within ON_STATION of a station.

    Rows are time-major, then station-major, then component (Ex, Ey, Ez): the paper's order.
    Row block of instant i is ``(∂h/∂X)(Φ^i x) · Φ^i``; Φ^i adds i·T·(∂/∂x, ∂/∂y) to the
    velocity columns (constant-velocity motion, no vertical speed). ``e`` (N_COMPONENTS,),
    ``jac`` (N_COMPONENTS, N_STATES) and ``w`` (the layered series' one-pair workspace) are scratch.
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
            _store_rows(station_rows(w, rx, ry, x[2], stations[s, 2], x[3], x[4], x[5], x[6], kappa,
                                     model, medium), e, jac)
            for comp in range(N_COMPONENTS):
                if row >= n_rows:
                    break
                for q in range(free.shape[0]):
                    col = free[q]
                    v = jac[comp, col]
                    if col == _VX:
                        v += dt * jac[comp, 0]  # Φ^i: ∂x_{k+i}/∂vx_k = i·T
                    elif col == _VY:
                        v += dt * jac[comp, 1]  # Φ^i: ∂y_{k+i}/∂vy_k = i·T
                    g[row, q] = v
                row += 1
        i += 1
    return True


@nb.njit(parallel=True, nogil=True, **JIT)
def fill_gamma(states, stations, step, kappa, model, medium, free, n_rows, out):
    """Γ for every state: states (P, N_STATES) -> out (P, n_rows, n_free) (NaN on stations)."""
    npts = states.shape[0]
    for b in nb.prange((npts + _BLOCK - 1) // _BLOCK):
        e = np.empty(N_COMPONENTS)
        jac = np.empty((N_COMPONENTS, N_STATES))
        w = np.empty((PAIR_ROWS, 1))
        for p in range(b * _BLOCK, min(npts, (b + 1) * _BLOCK)):
            if not _gamma_point(states[p], stations, step, kappa, model, medium, free, n_rows, e, jac,
                                w, out[p]):
                out[p] = np.nan


#: Points evaluated together by the map kernels. Each per-point quantity is a row of ``LANES``
#: values in one workspace, and every loop over a row compiles to AVX2 vector code: LLVM fully
#: unrolls shorter loops and then leaves them scalar (numba keeps SLP vectorisation off). With
#: a Householder QR instead of a pivoting LU (data-dependent row choices do not vectorise) the
#: square kernel measured ~2.8× faster than one point at a time (bench/bench_core.py).
LANES = 128
#: Work items of a map kernel's parallel loop, each a run of groups with one workspace: enough
#: for the scheduler to balance any likely thread count.
_CHUNKS = 64
# Workspace rows (each LANES wide), sized from the state and component counts: states
# (N_STATES), the current station's rows (E_i, ∂E_i/∂X) × N_COMPONENTS, Γ (N_STATES × N_STATES,
# row-major; R in the Fisher kernel), squared column norms, a row of Γ (Fisher; ROW wide),
# per-lane scalars, the layered series. (For the electric counts: 0, 7, 31, 80, 87, 95 … 99.)
_X = 0
_J = _X + N_STATES
_G = _J + STATION_ROWS
_SQ = _G + N_STATES * N_STATES
_T = _SQ + N_STATES
_NORM2 = _T + ROW
_DET, _BETA, _DOT, _BAD = _NORM2 + 1, _NORM2 + 2, _NORM2 + 3, _NORM2 + 4
#: Row stride of the square matrices in the workspace, and the step along their diagonal.
_N, _DIAG = N_STATES, N_STATES + 1
# The layered series' rows (core.kernels.sea.SEA_ROWS: a pair's inputs and its previous group), its
# outputs going straight to w[_J…]. In the Fisher kernel they share rows with the Givens and
# R⁻¹ scratch, which is dead while a station's rows are being computed.
_SEA = _BAD + 1
_ROWS = _SEA + SEA_ROWS


@nb.njit(inline="always", **JIT)
def _put_row(w, r0, lane, row):
    """w[r0 : r0 + ROW, lane] = row (one component's (E_i, ∂E_i/∂X))."""
    w[r0, lane], w[r0 + 1, lane], w[r0 + 2, lane], w[r0 + 3, lane] = row[0], row[1], row[2], row[3]
    w[r0 + 4, lane], w[r0 + 5, lane], w[r0 + 6, lane], w[r0 + 7, lane] = row[4], row[5], row[6], row[7]


@nb.njit(inline="always", **JIT)
def _jacobian_lanes(w, dt, stations, s, kappa, model, medium):
    """Rows (E_i, ∂E_i/∂X) of station ``s`` at time offset ``dt`` for the LANES states in
    w[_X:_X+N_STATES], into w[_J:_J+STATION_ROWS]. w[_BAD] = 1 where a target comes within ON_STATION of the
    station (its offset is replaced by a harmless one; the caller masks the result).

    A layered sea (medium[0] = D > 0) runs the image series on the LANES pairs side by side
    (:func:`core.kernels.sea.layered_lanes`, its groups in lockstep, its rows at w[_SEA…]); the whole
    space keeps the straight loop below. Both loops LLVM vectorises across lanes."""
    sx, sy, sz = stations[s, 0], stations[s, 1], stations[s, 2]
    if medium[0] > 0.0:
        for lane in range(LANES):
            rx = w[_X, lane] + dt * w[_X + 3, lane] - sx
            ry = w[_X + 1, lane] + dt * w[_X + 4, lane] - sy
            rz = w[_X + 2, lane] - sz
            near = rx * rx + ry * ry + rz * rz < ON_STATION * ON_STATION
            w[_BAD, lane] = 1.0 if near else w[_BAD, lane]
            w[_SEA, lane], w[_SEA + 1, lane] = 1.0 if near else rx, ry
            w[_SEA + 2, lane], w[_SEA + 3, lane] = w[_X + 2, lane], sz
            w[_SEA + 4, lane], w[_SEA + 5, lane] = w[_X + 3, lane], w[_X + 4, lane]
            w[_SEA + 6, lane], w[_SEA + 7, lane] = w[_X + 5, lane], w[_X + 6, lane]
        layered_lanes(w, _SEA, _J, LANES, kappa, medium[0], medium[1], medium[2])
        return
    for lane in range(LANES):
        rx = w[_X, lane] + dt * w[_X + 3, lane] - sx
        ry = w[_X + 1, lane] + dt * w[_X + 4, lane] - sy
        rz = w[_X + 2, lane] - sz
        near = rx * rx + ry * ry + rz * rz < ON_STATION * ON_STATION
        w[_BAD, lane] = 1.0 if near else w[_BAD, lane]
        rows = _local_jacobian(1.0 if near else rx, ry, rz, w[_X + 3, lane], w[_X + 4, lane],
                               w[_X + 5, lane], w[_X + 6, lane], kappa, model)
        _put_row(w, _J, lane, rows[0])
        _put_row(w, _J + ROW, lane, rows[1])
        _put_row(w, _J + 2 * ROW, lane, rows[2])


@nb.njit(inline="always", **JIT)
def _gamma_row_lanes(w, dst, comp, dt, free):
    """One row of Γ, component ``comp`` of w[_J…] at time offset ``dt``, into w[dst + q] for the
    free columns q. Φ^i adds i·T·(∂/∂x, ∂/∂y) to the velocity columns."""
    for q in range(free.shape[0]):
        col = free[q]
        src = _J + ROW * comp + 1 + col
        if col == _VX or col == _VY:  # Φ^i: ∂(x, y)_{k+i}/∂(vx, vy)_k = i·T
            pos = _J + ROW * comp + 1 + col - _VX
            for lane in range(LANES):
                w[dst + q, lane] = w[src, lane] + dt * w[pos, lane]
        else:
            for lane in range(LANES):
                w[dst + q, lane] = w[src, lane]


@nb.njit(inline="always", **JIT)
def _load_lanes(w, states, p0):
    """States p0 … p0 + LANES − 1 into w[_X:_X+N_STATES] (a short last group repeats its first point);
    clears w[_BAD]. Returns the number of real points."""
    count = min(LANES, states.shape[0] - p0)
    for lane in range(LANES):
        p = p0 + lane if lane < count else p0
        for k in range(N_STATES):
            w[_X + k, lane] = states[p, k]
        w[_BAD, lane] = 0.0
    return count


@nb.njit(inline="always", **JIT)
def _assemble_lanes(w, stations, step, kappa, model, medium, free):
    """Γ (paper rule: the first n_free rows, time-major, then station, then component) of the
    LANES states into w[_G + _N r + q]."""
    n = free.shape[0]
    row = 0
    i = 0
    while row < n:
        for s in range(stations.shape[0]):
            if row >= n:
                break
            _jacobian_lanes(w, i * step, stations, s, kappa, model, medium)
            for comp in range(N_COMPONENTS):
                if row >= n:
                    break
                _gamma_row_lanes(w, _G + _N * row, comp, i * step, free)
                row += 1
        i += 1


@nb.njit(inline="always", **JIT)
def _qr_abs_det_lanes(w, n):
    """w[_DET] = |det| of the n × n matrices in w[_G…] (destroyed), one per lane: the product
    of |R_kk| of a Householder QR. Branch-free across lanes (unlike pivoting), and backward
    stable; column scaling commutes with it, so none is needed."""
    for lane in range(LANES):
        w[_DET, lane] = 1.0
    for k in range(n):
        kk = _G + _DIAG * k
        for lane in range(LANES):
            w[_NORM2, lane] = 0.0  # ‖column k below the diagonal‖²
        for r in range(k, n):
            rk = _G + _N * r + k
            for lane in range(LANES):
                w[_NORM2, lane] += w[rk, lane] * w[rk, lane]
        for lane in range(LANES):
            norm2, top = w[_NORM2, lane], w[kk, lane]
            alpha = -math.sqrt(norm2) if top >= 0.0 else math.sqrt(norm2)
            v0 = top - alpha  # Householder vector v = x − α e₁, stored over column k
            vnorm2 = norm2 - top * top + v0 * v0
            w[kk, lane] = v0
            w[_BETA, lane] = 2.0 / vnorm2 if vnorm2 > 0.0 else 0.0
            w[_DET, lane] *= abs(alpha)
            w[_T, lane] = alpha  # R_kk, stored over v0 once the columns right of k are done
        for c in range(k + 1, n):
            for lane in range(LANES):
                w[_DOT, lane] = 0.0
            for r in range(k, n):
                rk, rc = _G + _N * r + k, _G + _N * r + c
                for lane in range(LANES):
                    w[_DOT, lane] += w[rk, lane] * w[rc, lane]
            for lane in range(LANES):
                w[_DOT, lane] *= w[_BETA, lane]
            for r in range(k, n):
                rk, rc = _G + _N * r + k, _G + _N * r + c
                for lane in range(LANES):
                    w[rc, lane] -= w[_DOT, lane] * w[rk, lane]
        for lane in range(LANES):
            w[kk, lane] = w[_T, lane]  # R (upper triangle, signed diagonal) is now in w[_G…]


@nb.njit(inline="always", **JIT)
def _rinv_scaled_frobenius2_lanes(w, n):
    """w[_NORM2] = ‖R_s⁻¹‖_F² = Σ_i ‖Γ_i‖² Σ_k (R⁻¹)_ik² for the R in w[_G…] (upper triangle)
    and the squared column norms in w[_SQ…], one column of R⁻¹ at a time (back substitution
    into the free rows w[_J:_J+N_STATES]). inf or NaN where an R_jj is 0."""
    for lane in range(LANES):
        w[_NORM2, lane] = 0.0
    for k in range(n):
        for i in range(k, -1, -1):
            xi = _J + i
            for lane in range(LANES):
                w[xi, lane] = 1.0 if i == k else 0.0
            for j in range(i + 1, k + 1):
                ij, xj = _G + _N * i + j, _J + j
                for lane in range(LANES):
                    w[xi, lane] -= w[ij, lane] * w[xj, lane]
            ii, si = _G + _DIAG * i, _SQ + i
            for lane in range(LANES):
                w[xi, lane] /= w[ii, lane]
                w[_NORM2, lane] += w[si, lane] * w[xi, lane] * w[xi, lane]


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
    workspace is allocated here once, with a shape known at compile time so that LLVM sees its
    row stride (and not per group: freeing it each time let malloc hand the pages back to the
    OS and fault them in again: a 40k-point map took 20–48 ms inside the server, 5–16 ms now)."""
    n = free.shape[0]
    w = np.empty((_ROWS, LANES))
    for group in range(first, last):
        p0 = group * LANES
        count = _load_lanes(w, states, p0)
        _assemble_lanes(w, stations, step, kappa, model, medium, free)
        for j in range(n):
            for lane in range(LANES):
                w[_SQ + j, lane] = 0.0
            for r in range(n):
                rj = _G + _N * r + j
                for lane in range(LANES):
                    w[_SQ + j, lane] += w[rj, lane] * w[rj, lane]
        _qr_abs_det_lanes(w, n)
        _rinv_scaled_frobenius2_lanes(w, n)
        for lane in range(count):
            p = p0 + lane
            if w[_BAD, lane] != 0.0:
                log_det[p] = np.nan
                log_eta[p] = np.nan
                log_rcond[p] = np.nan
                continue
            log_rcond[p] = _log10_rcond(w[_NORM2, lane], n)
            prod = 1.0
            for j in range(n):
                prod *= w[_SQ + j, lane]
            if 1e-300 < prod < 1e300:  # one logarithm on the hot path
                norms = 0.5 * math.log10(prod)
            else:
                norms = 0.0
                for j in range(n):
                    sq = w[_SQ + j, lane]
                    norms += 0.5 * math.log10(sq) if sq > 0.0 else -np.inf
            det = w[_DET, lane]
            ld = math.log10(det) if det > 0.0 else -np.inf
            log_det[p] = ld
            log_eta[p] = ld - norms


@nb.njit(parallel=True, nogil=True, **JIT)
def square_measures(states, stations, step, kappa, model, medium, free, log_det, log_eta,
                    log_rcond):
    """Paper rule: square Γ (n_free rows). Writes log10|det Γ|, log10 η and log10 rcond per
    point (NaN on stations), LANES points at a time."""
    groups = (states.shape[0] + LANES - 1) // LANES
    chunks = min(groups, _CHUNKS)
    for c in nb.prange(chunks):
        _square_groups(states, c * groups // chunks, (c + 1) * groups // chunks, stations, step, kappa,
                       model, medium, free, log_det, log_eta, log_rcond)


# Workspace rows of fisher_measures beyond the shared ones: R (N_STATES × N_STATES at _G), the
# incoming row of Γ (at _T), Givens cosines/sines, R⁻¹ (N_STATES × N_STATES).
_COS, _SIN, _RINV = _BAD + 1, _BAD + 2, _BAD + 3
_FISHER_ROWS = _RINV + N_STATES * N_STATES


@nb.njit(inline="always", **JIT)
def _givens_update(w, n):
    """Fold the row w[_T:_T+n] into the upper-triangular R (w[_G + _N j + k]) by Givens
    rotations: R ← the R of QR([R; row]), R_jj ≥ 0. Backward stable (forming ΓᵀΓ is not: it
    would square the round-off of an exactly singular Γ)."""
    for j in range(n):
        jj, tj = _G + _DIAG * j, _T + j
        for lane in range(LANES):
            a, b = w[jj, lane], w[tj, lane]
            r = math.sqrt(a * a + b * b)
            nonzero = r > 0.0
            w[_COS, lane] = a / r if nonzero else 1.0
            w[_SIN, lane] = b / r if nonzero else 0.0
            w[jj, lane] = r
        for k in range(j + 1, n):
            jk, tk = _G + _N * j + k, _T + k
            for lane in range(LANES):
                rk, xk, c, s = w[jk, lane], w[tk, lane], w[_COS, lane], w[_SIN, lane]
                w[jk, lane] = c * rk + s * xk
                w[tk, lane] = c * xk - s * rk


@nb.njit(inline="always", **JIT)
def _inverse_lanes(w, n):
    """R⁻¹ (upper triangular) into w[_RINV + _N i + k] by back substitution; inf/NaN where an
    R_jj is 0 (the caller masks those lanes)."""
    for k in range(n):
        for i in range(k, -1, -1):
            ik = _RINV + _N * i + k
            for lane in range(LANES):
                w[ik, lane] = 1.0 if i == k else 0.0
            for j in range(i + 1, k + 1):
                ij, jk = _G + _N * i + j, _RINV + _N * j + k
                for lane in range(LANES):
                    w[ik, lane] -= w[ij, lane] * w[jk, lane]
            ii = _G + _DIAG * i
            for lane in range(LANES):
                w[ik, lane] /= w[ii, lane]


@nb.njit(**JIT)
def _fisher_groups(states, first, last, stations, step, kappa, model, medium, free, n_rows,
                   log_eta, log_norm_sum, inv_diag, log_rcond):
    """:func:`fisher_measures` for the groups ``first`` … ``last − 1`` (see :func:`_square_groups`)."""
    n = free.shape[0]
    w = np.empty((_FISHER_ROWS, LANES))
    for group in range(first, last):
        p0 = group * LANES
        count = _load_lanes(w, states, p0)
        for r in range(_G, _G + N_STATES * N_STATES):
            w[r] = 0.0
        for j in range(n):
            w[_SQ + j] = 0.0
        for i in range(n_rows // (N_COMPONENTS * stations.shape[0])):
            for s in range(stations.shape[0]):
                _jacobian_lanes(w, i * step, stations, s, kappa, model, medium)
                for comp in range(N_COMPONENTS):
                    _gamma_row_lanes(w, _T, comp, i * step, free)
                    for j in range(n):
                        for lane in range(LANES):
                            w[_SQ + j, lane] += w[_T + j, lane] * w[_T + j, lane]
                    _givens_update(w, n)
        _inverse_lanes(w, n)
        for lane in range(count):
            p = p0 + lane
            if w[_BAD, lane] != 0.0:
                log_eta[p] = np.nan
                log_norm_sum[p] = np.nan
                inv_diag[p] = np.nan
                log_rcond[p] = np.nan
                continue
            norms = 0.0
            log_r = 0.0
            singular = False
            for j in range(n):
                sq, rjj = w[_SQ + j, lane], w[_G + _DIAG * j, lane]
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
                    v = w[_RINV + _N * i + k, lane]
                    acc += v * v
                # (ΓᵀΓ)⁻¹ = R⁻¹ R⁻ᵀ: its diagonal is the row sums of (R⁻¹)²
                inv_diag[p, i] = np.inf if singular else acc
                frob2 += w[_SQ + i, lane] * acc
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
    chunks = min(groups, _CHUNKS)
    for c in nb.prange(chunks):
        _fisher_groups(states, c * groups // chunks, (c + 1) * groups // chunks, stations, step, kappa,
                       model, medium, free, n_rows, log_eta, log_norm_sum, inv_diag, log_rcond)


@nb.njit(cache=True, nogil=True)
def grid_states(template, u, v, v_index, out):
    """States on a plane: out[i, j] = template with x = u[j] and state[v_index] = v[i].
    Serial: it is memory-bound, and a thread team costs more than it saves."""
    for i in range(v.shape[0]):
        for j in range(u.shape[0]):
            for k in range(template.shape[0]):
                out[i, j, k] = template[k]
            out[i, j, 0] = u[j]
            out[i, j, v_index] = v[i]
