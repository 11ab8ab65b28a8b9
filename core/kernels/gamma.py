"""Compiled kernels that build Γ, point by point and LANES points side by side, for every sensor
kind: the one place where a kind picks its measurement rows.

Private: they assume validated float64 input (see :mod:`core.model.validation`) and never allocate
per point. The measures reduced from Γ (log10|det Γ|, η, rcond, Fisher) are in :mod:`.measures`;
they run on the rows assembled here, whatever the kind.

The rows code (argument ``model``) picks the rows of one station and instant:

- 0, 1: the electric field (:mod:`.electric`, ``exact`` / ``paper``); ``medium`` = [D, η, tol]
  of :func:`core.model.sea.medium`: D = 0 the whole space, D > 0 the layered sea (:mod:`.sea`);
  ``kappa`` = 1/(4πσ). States ``[x, y, z, vx, vy, Ph, Pv]``, components (Ex, Ey, Ez).
- 2, 3, 4: the magnetic kinds B, G, BG (:mod:`.magnetic`); ``medium`` = [near, baseline,
  1/noise_B, 1/noise_G] (the rows come whitened); ``kappa`` unused. States
  ``[x, y, z, vx, vy, mx, my, mz]``, components B (3) then G (5).

Everything after the rows — Φ^i, Γ's row order, the QR, the rank test, the measures — is shared.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from . import magnetic as mk
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
from .sea import PAIR_ROWS, SEA_ROWS, _load, _store, layered_lanes, station_rows

_BLOCK = 256
#: State columns of the horizontal velocity (vx, vy): Φ^i adds i·T·∂/∂(x, y) to them.
_VX, _VY = 3, 4
#: Largest state of any kind (8, magnetic), and its rows per component (value + Jacobian).
NX = max(N_STATES, mk.N_STATE)
_MAX_ROW = max(ROW, mk.LANE_ROW)
#: Largest number of components of one station (8, BG).
MAX_COMPONENTS = max(N_COMPONENTS, mk.MAX_COMPONENTS)


@nb.njit(inline="always", **JIT)
def components(model):
    """Components per station of a rows code (module notes)."""
    return N_COMPONENTS if model < mk.CODE_B else mk.n_components(model)


@nb.njit(inline="always", **JIT)
def row_stride(model):
    """Workspace rows of one component of a rows code: electric ROW (8), magnetic 9."""
    return ROW if model < mk.CODE_B else mk.LANE_ROW


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


# One-point workspace of the magnetic rows in :func:`_gamma_point` (one lane wide): the state,
# the rows, the flag, the scratch.
_PX = 0
_PJ = _PX + mk.N_STATE
_PBAD = _PJ + mk.MAX_COMPONENTS * mk.LANE_ROW
_PSC = _PBAD + 1
_POINT_ROWS = _PSC + mk.LANE_SCRATCH


@nb.njit(inline="always", **JIT)
def _magnetic_point(wm, x, dt, stations, s, model, medium):
    """The magnetic rows (:func:`core.kernels.magnetic.rows_lanes`, one lane) of station ``s``
    at time offset ``dt`` for the state ``x`` into wm[_PJ…]; False if the target is within the
    kind's ``near``."""
    for k in range(mk.N_STATE):
        wm[_PX + k, 0] = x[k]
    wm[_PBAD, 0] = 0.0
    mk.rows_lanes(wm, _PX, _PJ, _PSC, _PBAD, 1, dt, stations[s, 0], stations[s, 1],
                  stations[s, 2], model, medium)
    return wm[_PBAD, 0] == 0.0


@nb.njit(**JIT)
def _station_point(x, dt, stations, s, kappa, model, medium, jac, w, wm):
    """Jacobian rows of station ``s`` at time offset ``dt`` for the state ``x`` into
    jac (components, NX). False if the target is on the station (within a magnetic kind's
    ``near``). ``w`` is the layered series' one-pair workspace, ``wm`` the magnetic one."""
    px = x[0] + dt * x[3]
    py = x[1] + dt * x[4]
    rx, ry, rz = px - stations[s, 0], py - stations[s, 1], x[2] - stations[s, 2]
    if model >= mk.CODE_B:
        ok = _magnetic_point(wm, x, dt, stations, s, model, medium)
        for comp in range(mk.n_components(model)):
            for k in range(mk.N_STATE):
                jac[comp, k] = wm[_PJ + mk.LANE_ROW * comp + 1 + k, 0]
        return ok
    if rx * rx + ry * ry + rz * rz < ON_STATION * ON_STATION:
        return False
    rows = station_rows(w, rx, ry, x[2], stations[s, 2], x[3], x[4], x[5], x[6], kappa, model,
                        medium)
    for comp in range(N_COMPONENTS):
        for k in range(N_STATES):
            jac[comp, k] = rows[comp][1 + k]
    return True


@nb.njit(nogil=True, **JIT)
def magnetic_rows_block(states, stations, dt, model, medium, h_out, j_out, lo, hi):
    """:func:`magnetic_rows` for the points lo ≤ p < hi, one lane at a time, on the calling thread
    (the front's path for at most ``core.kernels.magnetic.BLOCK`` points)."""
    wm = np.empty((_POINT_ROWS, 1))
    for p in range(lo, hi):
        for s in range(stations.shape[0]):
            on = not _magnetic_point(wm, states[p], dt, stations, s, model, medium)
            for c in range(h_out.shape[2]):
                r0 = _PJ + mk.LANE_ROW * c
                h_out[p, s, c] = np.nan if on else wm[r0, 0]
                for k in range(mk.N_STATE):
                    j_out[p, s, c, k] = np.nan if on else wm[r0 + 1 + k, 0]
                # the field does not depend on the velocity at one instant; Φ^i moves the position
                j_out[p, s, c, _VX] += dt * j_out[p, s, c, 0]
                j_out[p, s, c, _VY] += dt * j_out[p, s, c, 1]


@nb.njit(parallel=True, nogil=True, **JIT)
def magnetic_rows(states, stations, dt, model, medium, h_out, j_out):
    """Magnetic measurements h (P, S, C) and rows ∂h(Φ^i x)/∂x (P, S, C, 8) at time offset
    ``dt`` (= i·T) for states (P, 8): the map kernels' rows (:func:`core.kernels.magnetic.rows_lanes`,
    one lane at a time; ``model`` its kind's code, ``medium`` = [near, L, weight_B, weight_G]).
    NaN where a target is within ``near`` of a station."""
    npts = states.shape[0]
    for b in nb.prange((npts + _BLOCK - 1) // _BLOCK):
        magnetic_rows_block(states, stations, dt, model, medium, h_out, j_out, b * _BLOCK,
                             min(npts, (b + 1) * _BLOCK))


@nb.njit(**JIT)
def _gamma_point(x, stations, step, kappa, model, medium, free, n_rows, jac, w, wm, g):
    """Fill ``g`` (n_rows, n_free) with the first ``n_rows`` rows of Γ at state ``x``.
    Returns False, with ``g`` incomplete, if the target comes within ON_STATION of a station.

    Rows are time-major, then station-major, then component (Ex, Ey, Ez; or B then G): the
    paper's order. Row block of instant i is ``(∂h/∂X)(Φ^i x) · Φ^i``; Φ^i adds
    i·T·(∂/∂x, ∂/∂y) to the velocity columns (constant-velocity motion, no vertical speed).
    ``jac`` (MAX_COMPONENTS, NX), ``w`` and ``wm`` (:func:`_station_point`) are scratch.
    """
    n_s, n_c = stations.shape[0], components(model)
    row = 0
    i = 0
    while row < n_rows:
        dt = i * step
        for s in range(n_s):
            if row >= n_rows:
                break
            if not _station_point(x, dt, stations, s, kappa, model, medium, jac, w, wm):
                return False
            for comp in range(n_c):
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
    """Γ for every state: states (P, n_states) -> out (P, n_rows, n_free) (NaN on stations)."""
    npts = states.shape[0]
    for b in nb.prange((npts + _BLOCK - 1) // _BLOCK):
        jac = np.empty((MAX_COMPONENTS, NX))
        w = np.empty((PAIR_ROWS, 1))
        wm = np.empty((_POINT_ROWS, 1))
        for p in range(b * _BLOCK, min(npts, (b + 1) * _BLOCK)):
            if not _gamma_point(states[p], stations, step, kappa, model, medium, free, n_rows,
                                jac, w, wm, out[p]):
                out[p] = np.nan


#: Points evaluated together by the map kernels. Each per-point quantity is a row of ``LANES``
#: values in one workspace, and every loop over a row compiles to AVX2 vector code: LLVM fully
#: unrolls shorter loops and then leaves them scalar (numba keeps SLP vectorisation off). With
#: a Householder QR instead of a pivoting LU (data-dependent row choices do not vectorise) the
#: square kernel measured ~2.8× faster than one point at a time (bench/bench_core.py).
LANES = 128
#: Work items of a map kernel's parallel loop, each a run of groups with one workspace: enough
#: for the scheduler to balance any likely thread count.
CHUNKS = 64
# Workspace rows (each LANES wide), sized for the largest kind: states (NX), the current
# station's rows (value, Jacobian) × components, Γ (NX × NX, row-major; R in the Fisher kernel),
# squared column norms, a row of Γ (Fisher), per-lane scalars, the rows' scratch (the layered
# series, or the magnetic powers).
X = 0
J = X + NX
G = J + max(STATION_ROWS, mk.MAX_COMPONENTS * mk.LANE_ROW)
SQ = G + NX * NX
T = SQ + NX
NORM2 = T + _MAX_ROW
DET, BETA, DOT, BAD = NORM2 + 1, NORM2 + 2, NORM2 + 3, NORM2 + 4
#: Row stride of the square matrices in the workspace, and the step along their diagonal.
N, DIAG = NX, NX + 1
# The rows' scratch: the layered series' rows (core.kernels.sea.SEA_ROWS: a pair's inputs and
# its previous group, its outputs going straight to w[J…]) or the magnetic powers. In the
# Fisher kernel they share rows with the Givens and R⁻¹ scratch, which is dead while a
# station's rows are being computed.
SCRATCH = BAD + 1
ROWS = SCRATCH + max(SEA_ROWS, mk.LANE_SCRATCH)


@nb.njit(inline="always", **JIT)
def rows_lanes(w, dt, stations, s, kappa, model, medium):
    """Rows (value, Jacobian) of station ``s`` at time offset ``dt`` for the LANES states in
    w[X:X+NX], into w[J…] (stride :func:`row_stride`). w[BAD] = 1 where a target comes
    within ON_STATION (a magnetic kind's ``near``) of the station (its offset is replaced by a
    harmless one; the caller masks the result).

    The one place where the kind picks its rows: magnetic (:func:`core.kernels.magnetic.rows_lanes`),
    the layered sea (medium[0] = D > 0: :func:`core.kernels.sea.layered_lanes`, its groups in
    lockstep) or the whole space (the straight loop below). All of them LLVM vectorises
    across lanes."""
    sx, sy, sz = stations[s, 0], stations[s, 1], stations[s, 2]
    if model >= mk.CODE_B:
        mk.rows_lanes(w, X, J, SCRATCH, BAD, LANES, dt, sx, sy, sz, model, medium)
        return
    if medium[0] > 0.0:
        for lane in range(LANES):
            rx = w[X, lane] + dt * w[X + 3, lane] - sx
            ry = w[X + 1, lane] + dt * w[X + 4, lane] - sy
            rz = w[X + 2, lane] - sz
            near = rx * rx + ry * ry + rz * rz < ON_STATION * ON_STATION
            w[BAD, lane] = 1.0 if near else w[BAD, lane]
            w[SCRATCH, lane], w[SCRATCH + 1, lane] = 1.0 if near else rx, ry
            w[SCRATCH + 2, lane], w[SCRATCH + 3, lane] = w[X + 2, lane], sz
            w[SCRATCH + 4, lane], w[SCRATCH + 5, lane] = w[X + 3, lane], w[X + 4, lane]
            w[SCRATCH + 6, lane], w[SCRATCH + 7, lane] = w[X + 5, lane], w[X + 6, lane]
        layered_lanes(w, SCRATCH, J, LANES, kappa, medium[0], medium[1], medium[2])
        return
    for lane in range(LANES):
        rx = w[X, lane] + dt * w[X + 3, lane] - sx
        ry = w[X + 1, lane] + dt * w[X + 4, lane] - sy
        rz = w[X + 2, lane] - sz
        near = rx * rx + ry * ry + rz * rz < ON_STATION * ON_STATION
        w[BAD, lane] = 1.0 if near else w[BAD, lane]
        rows = _local_jacobian(1.0 if near else rx, ry, rz, w[X + 3, lane], w[X + 4, lane],
                               w[X + 5, lane], w[X + 6, lane], kappa, model)
        _store(w, J, lane, rows)


@nb.njit(inline="always", **JIT)
def gamma_row_lanes(w, dst, comp, stride, dt, free):
    """One row of Γ, component ``comp`` of w[J…] (rows ``stride`` apart) at time offset
    ``dt``, into w[dst + q] for the free columns q. Φ^i adds i·T·(∂/∂x, ∂/∂y) to the velocity
    columns."""
    for q in range(free.shape[0]):
        col = free[q]
        src = J + stride * comp + 1 + col
        if col == _VX or col == _VY:  # Φ^i: ∂(x, y)_{k+i}/∂(vx, vy)_k = i·T
            pos = J + stride * comp + 1 + col - _VX
            for lane in range(LANES):
                w[dst + q, lane] = w[src, lane] + dt * w[pos, lane]
        else:
            for lane in range(LANES):
                w[dst + q, lane] = w[src, lane]


@nb.njit(inline="always", **JIT)
def load_lanes(w, states, p0):
    """States p0 … p0 + LANES − 1 into w[X:X+n_states] (a short last group repeats its first
    point); clears w[BAD]. Returns the number of real points."""
    count = min(LANES, states.shape[0] - p0)
    for lane in range(LANES):
        p = p0 + lane if lane < count else p0
        for k in range(states.shape[1]):
            w[X + k, lane] = states[p, k]
        w[BAD, lane] = 0.0
    return count


@nb.njit(inline="always", **JIT)
def assemble_lanes(w, stations, step, kappa, model, medium, free):
    """Γ (paper rule: the first n_free rows, time-major, then station, then component) of the
    LANES states into w[G + N r + q]."""
    n = free.shape[0]
    n_c, stride = components(model), row_stride(model)
    row = 0
    i = 0
    while row < n:
        for s in range(stations.shape[0]):
            if row >= n:
                break
            rows_lanes(w, i * step, stations, s, kappa, model, medium)
            for comp in range(n_c):
                if row >= n:
                    break
                gamma_row_lanes(w, G + N * row, comp, stride, i * step, free)
                row += 1
        i += 1


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
